//! The console's state and its rules: one robot link, the latest
//! telemetry, the model's prediction, the interlock, the tab that drives,
//! the plan and its run. Every request a tab sends is judged here
//! ([`Console::handle`]); the web server only carries messages.

use std::path::PathBuf;
use std::sync::atomic::{AtomicBool, AtomicU64, AtomicUsize, Ordering};
use std::sync::{Arc, Mutex, MutexGuard, PoisonError};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use leech::geom::Vec2;
use leech::robot::Robot;
use leech::scene::{Scene, Solid};
use leech::stance::{self, FreeCups, Held, Hold};
use leech::statics::Solver;
use leech::stride::{self, Evidence, Foothold, Goal, Holding, Phase, StrideMachine};
use leech_link::executor::{self, Executor, Move};
use leech_link::host::{Event, Link, LinkError, Options};
use leech_link::pty::PtyDevice;
use leech_link::sim::Sim;
use leech_protocol::message::{Cup, Faults, Telemetry, Tube, NO_SENSOR};
use serde::Serialize;
use serde_json::json;

use crate::messages::{CupName, Execute, Refusal, Request};
use crate::model::{self, Drawing, Model, Prediction};

/// The telemetry period the console asks for (ms): 100 Hz, the protocol's
/// fastest, so that a slider's move shows in the drawing soon after the
/// tube starts (the page draws at 50 Hz).
pub const TELEMETRY_MS: u16 = 10;

/// The longest jog one request may ask for (mm).
pub const MAX_JOG_MM: f64 = 50.0;

/// How long the planner may search (s).
pub const PLAN_SECONDS: u64 = 120;

/// The workspace overlay's grid step over the tube lengths (m).
pub const WORKSPACE_STEP_M: f64 = 0.01;

/// Where the robot is.
#[derive(Clone, Debug)]
pub enum Source {
    /// The built-in simulated controller, its body on the scene.
    Simulated,
    /// A controller on a serial port.
    Port(PathBuf),
}

/// What the console drives: the robot, its surroundings, where its rear
/// cup starts, the scenario's goal (if any), and where the robot is.
#[derive(Clone, Debug)]
pub struct Setup {
    /// The robot file's model.
    pub robot: Robot,
    /// The scene around it.
    pub scene: Scene,
    /// The rear cup's starting foothold (the simulated body's, and the
    /// model's until the telemetry says a cup holds elsewhere).
    pub start: Foothold,
    /// The goal a plan is asked for by default.
    pub goal: Option<Goal>,
    /// The link.
    pub source: Source,
}

/// Why the console could not start.
#[derive(Debug, thiserror::Error)]
pub enum StartError {
    /// The simulated robot's pseudo-terminal.
    #[error("cannot start the simulated robot: {0}")]
    Simulator(#[from] leech_link::pty::PtyError),
    /// The link or its configuration.
    #[error(transparent)]
    Link(#[from] LinkError),
    /// A thread could not start.
    #[error("cannot start a thread: {0}")]
    Thread(std::io::Error),
}

/// The latest of what the robot reports.
#[derive(Default)]
struct Live {
    telemetry: Option<(Telemetry, Instant)>,
    /// The targets last sent (um), `None` after a stop.
    commanded_um: Option<[i32; 3]>,
    /// Faults and link events, newest last.
    notices: Vec<String>,
}

/// Notices kept for the page.
const NOTICES: usize = 6;

/// A plan and how far its run has come.
struct PlanState {
    /// Which plan (a run advances only its own plan's progress).
    id: u64,
    moves: Vec<Move>,
    /// The next step to carry out.
    next: usize,
}

/// What the executor's thread is doing.
#[derive(Clone, Debug, Default, Serialize)]
pub struct Run {
    /// Whether a step or plan is being carried out.
    pub busy: bool,
    /// What: `stride push`, `plan`.
    pub what: String,
    /// The plan's next step and its number of steps (0 without a plan).
    pub next_step: usize,
    /// Steps in the plan.
    pub steps: usize,
    /// How the last run ended, when it failed.
    pub error: Option<String>,
}

/// Everything the threads share.
struct Shared {
    robot: Robot,
    scene: Scene,
    goal: Option<Goal>,
    /// What the page shows (m): x0, y0, x1, y1.
    view_m: [f64; 4],
    source: String,
    link: Arc<Link>,
    live: Mutex<Live>,
    prediction: Mutex<Arc<Prediction>>,
    /// The equilibrium the prediction draws.
    held: Mutex<Option<Held>>,
    /// Signals a new prediction: the state goes out at once, not at the next tick.
    predicted: Arc<tokio::sync::Notify>,
    /// A reach, plan or workspace being computed (one at a time).
    computing: AtomicBool,
    driver: Mutex<Option<u64>>,
    plan: Mutex<Option<PlanState>>,
    /// The last plan's id.
    plan_ids: AtomicU64,
    /// A plan is being computed: nothing may be executed until it arrives.
    planning: AtomicBool,
    run: Mutex<Run>,
    /// Asks a running plan to stop after its step.
    cancel: AtomicBool,
    quit: AtomicBool,
    tabs: AtomicUsize,
    next_tab: AtomicU64,
    started: Instant,
    /// The workspace overlay for a driving unit's angle (rad, rounded to
    /// 0.01 rad): endpoints relative to the unit (m).
    workspace: Mutex<Option<(i64, Arc<Vec<Vec2>>)>>,
}

/// Locks `mutex`; a panic while it was held leaves usable data behind.
fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    mutex.lock().unwrap_or_else(PoisonError::into_inner)
}

/// The console (module doc). Dropping it stops its threads, the link and
/// the simulated robot.
pub struct Console {
    shared: Arc<Shared>,
    threads: Vec<JoinHandle<()>>,
    /// Kept running while the console lives.
    _device: Option<PtyDevice>,
}

impl Drop for Console {
    fn drop(&mut self) {
        self.shared.quit.store(true, Ordering::SeqCst);
        self.shared.cancel.store(true, Ordering::SeqCst);
        for t in self.threads.drain(..) {
            let _ = t.join();
        }
    }
}

/// A reply to a request that only the asking tab sees.
pub type Reply = serde_json::Value;

/// Sends a tab a message later (a reach, a plan, a workspace).
pub type Later = Box<dyn Fn(Reply) + Send + Sync>;

impl Console {
    /// Opens the link (starting the simulated robot first, if asked),
    /// configures the tubes from the robot file, asks for telemetry and
    /// starts following it. The simulated robot's rear pump is switched on,
    /// so that it starts held on its foothold as a climb does.
    pub fn start(setup: Setup) -> Result<Console, StartError> {
        let Setup { robot, scene, start, goal, source } = setup;
        let (device, path, name) = match source {
            Source::Simulated => {
                let body = leech_link::body::BodyCups::new(robot.clone(), scene.clone(), start);
                let sim = Sim::with_cups(leech_link::settings::sim_config(&robot), Box::new(body));
                let device = PtyDevice::spawn(sim)?;
                let path = device.path().to_path_buf();
                (Some(device), path, "simulated robot".to_string())
            }
            Source::Port(path) => {
                let name = format!("port {}", path.display());
                (None, path, name)
            }
        };
        let link = Link::open(&path, Options::default())?;
        for tube in leech_link::settings::tube_configs(&robot) {
            link.configure_tube(tube)?;
        }
        let events = link.subscribe();
        link.set_telemetry(TELEMETRY_MS)?;
        if device.is_some() {
            link.pump(Cup::Rear, true)?;
        }
        let shared = Arc::new(Shared {
            robot: robot.clone(),
            scene: scene.clone(),
            goal,
            view_m: view(&robot, start, goal),
            source: name,
            link: Arc::new(link),
            live: Mutex::default(),
            prediction: Mutex::default(),
            held: Mutex::new(None),
            predicted: Arc::new(tokio::sync::Notify::new()),
            computing: AtomicBool::new(false),
            driver: Mutex::new(None),
            plan: Mutex::new(None),
            plan_ids: AtomicU64::new(0),
            planning: AtomicBool::new(false),
            run: Mutex::default(),
            cancel: AtomicBool::new(false),
            quit: AtomicBool::new(false),
            tabs: AtomicUsize::new(0),
            next_tab: AtomicU64::new(1),
            started: Instant::now(),
            workspace: Mutex::new(None),
        });
        let spawn = |name: &str, f: Box<dyn FnOnce() + Send>| {
            std::thread::Builder::new().name(name.into()).spawn(f).map_err(StartError::Thread)
        };
        let follow = {
            let shared = Arc::clone(&shared);
            spawn("console-events", Box::new(move || follow_events(&shared, &events)))?
        };
        let predict = {
            let shared = Arc::clone(&shared);
            let model = Model::new(robot, scene, start);
            spawn("console-model", Box::new(move || follow_model(&shared, model)))?
        };
        Ok(Console { shared, threads: vec![follow, predict], _device: device })
    }
}

/// The part of the scene the page shows (m: x0, y0, x1, y1): around the
/// starting foothold as far as the tubes reach, and the goal.
fn view(robot: &Robot, start: Foothold, goal: Option<Goal>) -> [f64; 4] {
    let [x, y] = start.centre_m;
    let reach = robot.limits.tube_length_max_m * 1.1;
    let mut view = [x - reach, y - reach, x + reach, y + reach];
    if let Some(g) = goal {
        let [gx, gy] = g.point_m;
        let margin = 0.5 * reach;
        view = [view[0].min(gx - margin), view[1].min(gy - margin), view[2].max(gx + margin), view[3].max(gy + margin)];
    }
    view
}

/// Keeps the latest telemetry and notes faults and link events.
fn follow_events(shared: &Shared, events: &std::sync::mpsc::Receiver<Event>) {
    while !shared.quit.load(Ordering::SeqCst) {
        let event = match events.recv_timeout(Duration::from_millis(50)) {
            Ok(event) => event,
            Err(std::sync::mpsc::RecvTimeoutError::Timeout) => continue,
            Err(std::sync::mpsc::RecvTimeoutError::Disconnected) => return,
        };
        let mut live = lock(&shared.live);
        let notice = match event {
            Event::Telemetry(t) => {
                if live.commanded_um.is_none() && live.telemetry.is_none() {
                    live.commanded_um = Some(t.lengths_um);
                }
                live.telemetry = Some((t, Instant::now()));
                continue;
            }
            Event::Fault { code, detail, .. } => {
                let name = Faults::name(code).map_or_else(|| format!("bit {code}"), str::to_string);
                format!("fault: {name} (detail {detail})")
            }
            Event::NoAnswer { command, .. } => format!("link: no answer to {command}"),
            Event::Disconnected => "link: the port failed; reconnecting".into(),
            Event::Reconnected(_) => "link: reconnected".into(),
            Event::DeviceReset(_) => "link: the device reset (its pumps are off)".into(),
            Event::Restored(r) => format!("link: configuration restored ({} tube(s) lost)", r.lost.0.count_ones()),
        };
        let t = shared.started.elapsed().as_secs_f64();
        live.notices.push(format!("{t:.1} s: {notice}"));
        let excess = live.notices.len().saturating_sub(NOTICES);
        live.notices.drain(..excess);
    }
}

/// Solves the model whenever the telemetry's lengths or holds change.
///
/// A solve takes milliseconds to tens of them and runs back to back while
/// the tubes move: the thread rests at least as long as it solved, so
/// that it takes at most half a core and the link's and the simulated
/// controller's threads (whose deadlines are real: 500 ms without a frame
/// is a lost link) keep their share on a small machine.
fn follow_model(shared: &Shared, mut model: Model) {
    while !shared.quit.load(Ordering::SeqCst) {
        let seen = lock(&shared.live).telemetry.as_ref().map(|(t, _)| observation(t));
        if let Some((lengths, pumps, holding)) = seen {
            model.observe(lengths, pumps, holding);
        }
        let started = Instant::now();
        if let Some((p, held)) = model.predict() {
            *lock(&shared.prediction) = Arc::new(p);
            *lock(&shared.held) = held;
            shared.predicted.notify_one();
        }
        std::thread::sleep(started.elapsed().max(Duration::from_millis(5)));
    }
}

/// Lengths (m), pumps and holds from a telemetry report.
fn observation(t: &Telemetry) -> ([f64; 3], [bool; 2], [bool; 2]) {
    let pair = |set: leech_protocol::message::CupSet| [set.contains(Cup::Rear), set.contains(Cup::Front)];
    (t.lengths_um.map(|l| f64::from(l) / 1e6), pair(t.pumps), pair(t.holding))
}

/// Whether a stride phase may go now, and why not.
#[derive(Clone, Debug, Serialize)]
pub struct PhaseState {
    /// The phase's name.
    pub phase: &'static str,
    /// Whether the interlock allows it now.
    pub allowed: bool,
    /// Why not.
    pub reason: Option<String>,
}

/// The phases a tab may ask for by hand, in a stride's order.
const HAND_PHASES: [Phase; 6] =
    [Phase::Push, Phase::AttachFront, Phase::ReleaseRear, Phase::Pull, Phase::AttachRear, Phase::ReleaseFront];

/// The page's picture of the telemetry.
#[derive(Serialize)]
struct TelemetryView {
    device_time_s: f64,
    age_ms: f64,
    lengths_m: [f64; 3],
    duty_permille: [i16; 3],
    moving: [bool; 3],
    pumps_on: [bool; 2],
    holding: [bool; 2],
    vacuum_kpa: [Option<f64>; 2],
    faults: String,
    device_bad_crc: u16,
    device_bad_frames: u16,
    device_duplicates: u16,
}

/// The link's health.
#[derive(Serialize)]
struct HealthView {
    connected: bool,
    latency_ms: Option<f64>,
    mean_latency_ms: Option<f64>,
    sent: u64,
    retries: u64,
    give_ups: u64,
    bad_crc: u64,
    bad_frames: u64,
    reconnects: u64,
}

/// The state every tab is sent many times a second.
#[derive(Serialize)]
struct Snapshot<'a> {
    #[serde(rename = "type")]
    kind: &'static str,
    server_time_s: f64,
    driver: Option<u64>,
    tabs: usize,
    telemetry: Option<TelemetryView>,
    commanded_m: Option<[f64; 3]>,
    link: HealthView,
    prediction: &'a Prediction,
    holding: Option<[bool; 2]>,
    min_safety_factor: f64,
    phases: Vec<PhaseState>,
    run: Run,
    notices: Vec<String>,
}

/// The interlock's evidence for `phase` from the prediction: a free cup's
/// face flush, the other cup's safety factor after a release (NaN, which
/// the interlock refuses, when the model has none).
fn evidence(phase: Phase, body: Option<&Drawing>) -> Evidence {
    let cup = match phase {
        Phase::AttachRear | Phase::ReleaseRear => 0,
        _ => 1,
    };
    let c = body.map(|b| &b.cups[cup]);
    Evidence {
        flush: c.is_some_and(|c| c.flush),
        safety_factor: c.and_then(|c| c.other_after_release).unwrap_or(f64::NAN),
    }
}

impl Console {
    /// Notified whenever the model has a new prediction.
    pub fn predicted(&self) -> Arc<tokio::sync::Notify> {
        Arc::clone(&self.shared.predicted)
    }

    /// A new tab's number (never reused).
    pub fn connect(&self) -> u64 {
        self.shared.tabs.fetch_add(1, Ordering::SeqCst);
        self.shared.next_tab.fetch_add(1, Ordering::SeqCst)
    }

    /// A tab went away: it no longer drives.
    pub fn disconnect(&self, tab: u64) {
        self.shared.tabs.fetch_sub(1, Ordering::SeqCst);
        let mut driver = lock(&self.shared.driver);
        if *driver == Some(tab) {
            *driver = None;
        }
    }

    /// What a tab is told once, on connecting: the robot, the scene, the view.
    pub fn hello(&self, tab: u64) -> Reply {
        let s = &self.shared;
        let r = &s.robot;
        let (lo, hi) = (r.limits.tube_length_min_m, r.limits.tube_length_max_m);
        let view = s.view_m;
        json!({
            "type": "hello",
            "tab": tab,
            "source": s.source,
            "robot": {
                "name": r.name,
                "tube_length_min_m": lo,
                "tube_length_max_m": hi,
                "cup_diameter_m": r.cup.diameter_m,
                "min_safety_factor": r.cup.min_safety_factor,
                "max_jog_mm": MAX_JOG_MM,
            },
            "scene": { "name": s.scene.name, "solids": solids(&s.scene, view) },
            "view_m": view,
            "goal": s.goal.map(|g| json!({ "point_m": g.point_m, "tolerance_m": g.tolerance_m })),
            "phases": HAND_PHASES.map(Phase::name),
            "scenarios": stride::scenario::BUILTIN_SCENARIOS
                .iter()
                .filter(|b| stride::Scenario::builtin(b.name).is_ok_and(|sc| sc.scene == s.scene))
                .map(|b| b.name)
                .collect::<Vec<_>>(),
        })
    }

    /// The state as JSON, for every tab.
    pub fn snapshot(&self) -> String {
        let s = &self.shared;
        let live = lock(&s.live);
        let prediction = Arc::clone(&lock(&s.prediction));
        let health = s.link.health();
        let ms = |d: Duration| d.as_secs_f64() * 1e3;
        let mean = (!health.round_trips.is_empty())
            .then(|| health.round_trips.iter().map(|d| ms(*d)).sum::<f64>() / health.round_trips.len() as f64);
        let run = lock(&s.run).clone();
        let holding = live.telemetry.as_ref().map(|(t, _)| observation(t).2);
        let phases = HAND_PHASES
            .iter()
            .map(|&phase| {
                let reason = self.phase_refusal(phase, holding, &prediction, &run).err();
                PhaseState { phase: phase.name(), allowed: reason.is_none(), reason }
            })
            .collect();
        let snapshot = Snapshot {
            kind: "state",
            server_time_s: s.started.elapsed().as_secs_f64(),
            driver: *lock(&s.driver),
            tabs: s.tabs.load(Ordering::SeqCst),
            telemetry: live.telemetry.as_ref().map(|(t, at)| {
                let (lengths_m, pumps_on, holding) = observation(t);
                TelemetryView {
                    device_time_s: f64::from(t.time_ms) / 1e3,
                    age_ms: ms(at.elapsed()),
                    lengths_m,
                    duty_permille: t.duty_permille,
                    moving: Tube::ALL.map(|tube| t.active.contains(tube)),
                    pumps_on,
                    holding,
                    vacuum_kpa: t.vacuum_kpa_x10.map(|v| (v != NO_SENSOR).then(|| f64::from(v) / 10.0)),
                    faults: t.faults.to_string(),
                    device_bad_crc: t.counters.bad_crc,
                    device_bad_frames: t.counters.bad_frames,
                    device_duplicates: t.counters.duplicates,
                }
            }),
            commanded_m: live.commanded_um.map(|c| c.map(|l| f64::from(l) / 1e6)),
            link: HealthView {
                connected: health.connected,
                latency_ms: health.last_round_trip().map(ms),
                mean_latency_ms: mean,
                sent: health.sent,
                retries: health.resends,
                give_ups: health.give_ups,
                bad_crc: health.bad_crc,
                bad_frames: health.bad_frames,
                reconnects: health.reconnects,
            },
            prediction: &prediction,
            holding,
            min_safety_factor: s.robot.cup.min_safety_factor,
            phases,
            run,
            notices: live.notices.clone(),
        };
        serde_json::to_string(&snapshot)
            .unwrap_or_else(|e| json!({"type": "error", "message": e.to_string()}).to_string())
    }

    /// Whether the interlock allows `phase` now (ignoring who drives), and
    /// why not.
    fn phase_refusal(
        &self,
        phase: Phase,
        holding: Option<[bool; 2]>,
        prediction: &Prediction,
        run: &Run,
    ) -> Result<(), String> {
        if run.busy {
            return Err(format!("{} is running; stop it first", run.what));
        }
        interlock(&self.shared, phase, holding, prediction)
    }
}

/// Whether the interlock allows `phase` now on the model's evidence, and
/// why not (whatever runs).
fn interlock(s: &Shared, phase: Phase, holding: Option<[bool; 2]>, prediction: &Prediction) -> Result<(), String> {
    let Some([rear, front]) = holding else { return Err("no telemetry yet".into()) };
    let machine = StrideMachine::with_holding(Holding { rear, front }, s.robot.cup.min_safety_factor)
        .map_err(|e| format!("the interlock cannot start: {e}"))?;
    let body = prediction.body.as_ref();
    machine.check(phase.command(evidence(phase, body))).map(|_| ()).map_err(|e| e.to_string())
}

/// How long a run waits for the model to catch up with the telemetry
/// before a cup's step.
const LIVE_CHECK: Duration = Duration::from_secs(3);

/// The console's live interlock before a plan's or a hand's cup step: the
/// model's prediction for the measured lengths must allow `phase`
/// (waiting up to [`LIVE_CHECK`] for the model to catch up with the last
/// move), as a hand stride must.
fn live_interlock(s: &Shared, phase: Phase) -> Result<(), String> {
    let end = Instant::now() + LIVE_CHECK;
    loop {
        let measured = lock(&s.live).telemetry.as_ref().map(|(t, _)| observation(t));
        let prediction = Arc::clone(&lock(&s.prediction));
        let current = match (&measured, prediction.body.as_ref()) {
            (Some((l, _, _)), Some(b)) => (b.lengths_m[0] - l[0]).abs() < 1e-3 && (b.lengths_m[1] - l[1]).abs() < 1e-3,
            _ => false,
        };
        let verdict = interlock(s, phase, measured.map(|m| m.2), &prediction);
        match verdict {
            Ok(()) if current => return Ok(()),
            _ if Instant::now() >= end || s.cancel.load(Ordering::SeqCst) => {
                return Err(verdict.err().unwrap_or_else(|| "the model lags the measured lengths".into()))
            }
            _ => std::thread::sleep(Duration::from_millis(20)),
        }
    }
}

/// The scene's solids as polygons (m) for the page: a half-plane becomes
/// a rectangle covering `view` (x0, y0, x1, y1) and more.
fn solids(scene: &Scene, view: [f64; 4]) -> Vec<Vec<Vec2>> {
    let far = 2.0 * ((view[2] - view[0]).abs() + (view[3] - view[1]).abs()) + 1.0;
    scene
        .solids
        .iter()
        .map(|solid| match solid {
            Solid::Polygon { points_m } => points_m.clone(),
            Solid::HalfPlane { point_m, normal } => {
                let t = [-normal[1], normal[0]];
                let centre = [0.5 * (view[0] + view[2]), 0.5 * (view[1] + view[3])];
                // The line's point nearest the view's centre.
                let along = (centre[0] - point_m[0]) * t[0] + (centre[1] - point_m[1]) * t[1];
                let p = [point_m[0] + along * t[0], point_m[1] + along * t[1]];
                let at = |s: f64, d: f64| [p[0] + s * t[0] - d * normal[0], p[1] + s * t[1] - d * normal[1]];
                vec![at(-far, 0.0), at(far, 0.0), at(far, far), at(-far, far)]
            }
        })
        .collect()
}

/// Refuses `name` while `run` is busy.
fn idle_run(name: &str, run: &Run) -> Result<(), Refusal> {
    if run.busy {
        Err(Refusal::new(name, "run", &run.what, "nothing running", "a run is going on; stop it first"))
    } else {
        Ok(())
    }
}

/// A link error as a refusal of `request`.
fn link_refusal(request: &str, e: LinkError) -> Refusal {
    Refusal::new(
        request,
        "link",
        format!("{request} (sent to the controller)"),
        "a command the controller accepts over a working link",
        format!("the controller or the link refused {request}: {e}"),
    )
}

/// The stride's name of a cup.
fn stride_cup(cup: CupName) -> (stride::Cup, Cup) {
    match cup {
        CupName::Rear => (stride::Cup::Rear, Cup::Rear),
        CupName::Front => (stride::Cup::Front, Cup::Front),
    }
}

impl Console {
    /// Judges and carries out one request of tab `tab`: the immediate
    /// answer, or a refusal saying which field broke which rule (nothing
    /// changed then). A reach, a plan or the workspace is computed on a
    /// thread of its own and handed to `later` when done.
    pub fn handle(&self, tab: u64, request: Request, later: Later) -> Result<Reply, Refusal> {
        let name = request.name();
        let ok = |extra: serde_json::Value| {
            let mut reply = json!({ "type": "ok", "request": name });
            if let (Some(r), serde_json::Value::Object(e)) = (reply.as_object_mut(), extra) {
                r.extend(e);
            }
            Ok(reply)
        };
        let s = &self.shared;
        match request {
            Request::TakeControl {} => {
                let mut driver = lock(&s.driver);
                match *driver {
                    Some(d) if d != tab => Err(Refusal::new(
                        name,
                        "control",
                        format!("tab {tab}"),
                        format!("the driving tab {d}, or any tab once it releases control or closes"),
                        format!("tab {d} drives; one tab drives at a time"),
                    )),
                    _ => {
                        *driver = Some(tab);
                        ok(json!({}))
                    }
                }
            }
            Request::ReleaseControl {} => {
                let mut driver = lock(&s.driver);
                if *driver == Some(tab) {
                    *driver = None;
                }
                ok(json!({}))
            }
            // Any tab may stop the robot: it only makes things safer.
            Request::Stop {} => {
                s.cancel.store(true, Ordering::SeqCst);
                s.link.stop().map_err(|e| link_refusal(name, e))?;
                lock(&s.live).commanded_um = None;
                ok(json!({}))
            }
            Request::SetLengths { lengths_m } => {
                self.may_drive(tab, name)?;
                self.idle(name)?;
                for (i, l) in lengths_m.iter().enumerate() {
                    self.check_length(name, &format!("lengths_m[{i}]"), *l)?;
                }
                let um = lengths_m.map(|l| (l * 1e6).round() as i32);
                s.link.set_lengths(um).map_err(|e| link_refusal(name, e))?;
                lock(&s.live).commanded_um = Some(um);
                self.drop_plan();
                ok(json!({}))
            }
            Request::Jog { tube, delta_mm } => {
                self.may_drive(tab, name)?;
                self.idle(name)?;
                let t = match tube {
                    1 => Tube::L1,
                    2 => Tube::L2,
                    3 => Tube::L3,
                    _ => return Err(Refusal::new(name, "tube", tube, "1, 2 or 3", "no such tube")),
                };
                if !(delta_mm.is_finite() && delta_mm.abs() <= MAX_JOG_MM) {
                    return Err(Refusal::new(
                        name,
                        "delta_mm",
                        delta_mm,
                        format!("a distance within +-{MAX_JOG_MM} mm"),
                        "jog too far",
                    ));
                }
                let from = {
                    let live = lock(&s.live);
                    live.commanded_um.or(live.telemetry.as_ref().map(|(t, _)| t.lengths_um))
                };
                let Some(from) = from else {
                    return Err(Refusal::new(name, "telemetry", "none", "a robot that reports", "no telemetry yet"));
                };
                let delta_um = (delta_mm * 1e3).round() as i32;
                let target = from[t.index()] + delta_um;
                self.check_length(name, "delta_mm", f64::from(target) / 1e6).map_err(|mut r| {
                    r.value = format!("{delta_mm} (to {:.1} mm)", f64::from(target) / 1e3);
                    r
                })?;
                // Sent as targets for all three, not as the protocol's Jog: the
                // limit was judged on this target, and the others keep theirs.
                let mut targets = from;
                targets[t.index()] = target;
                s.link.set_lengths(targets).map_err(|e| link_refusal(name, e))?;
                lock(&s.live).commanded_um = Some(targets);
                self.drop_plan();
                ok(json!({}))
            }
            Request::Pump { cup, on } => {
                self.may_drive(tab, name)?;
                let (stride_cup, wire) = stride_cup(cup);
                let holding = lock(&s.live).telemetry.as_ref().map(|(t, _)| observation(t).2);
                let Some(holding) = holding else {
                    return Err(Refusal::new(name, "telemetry", "none", "a robot that reports", "no telemetry yet"));
                };
                // A free cup's pump switched on while the other cup holds is
                // an attach, a holding cup's switched off a release: the
                // interlock judges both (module doc).
                let judged = match (on, holding[wire.index()], stride_cup) {
                    (true, false, stride::Cup::Rear) if holding.contains(&true) => Some(Phase::AttachRear),
                    (true, false, stride::Cup::Front) if holding.contains(&true) => Some(Phase::AttachFront),
                    (false, true, stride::Cup::Rear) => Some(Phase::ReleaseRear),
                    (false, true, stride::Cup::Front) => Some(Phase::ReleaseFront),
                    _ => None,
                };
                if let Some(phase) = judged {
                    let (value, allowed) = if on {
                        (
                            format!("true ({} cup, free)", stride_cup.name()),
                            format!("false; true only while the {} cup's face lies flush", stride_cup.name()),
                        )
                    } else {
                        (
                            format!("false ({} cup)", stride_cup.name()),
                            format!(
                                "true; false only while the {} cup would hold alone with a safety factor of at least {}",
                                stride_cup.other().name(),
                                s.robot.cup.min_safety_factor
                            ),
                        )
                    };
                    let prediction = Arc::clone(&lock(&s.prediction));
                    let run = lock(&s.run).clone();
                    self.phase_refusal(phase, Some(holding), &prediction, &run)
                        .map_err(|why| Refusal::new(name, "on", value, allowed, why))?;
                }
                self.idle(name)?;
                s.link.pump(wire, on).map_err(|e| link_refusal(name, e))?;
                self.drop_plan();
                ok(json!({}))
            }
            Request::Stride { phase, lengths_m } => {
                self.may_drive(tab, name)?;
                let allowed = HAND_PHASES.map(Phase::name).join(", ");
                let Some(p) = Phase::from_name(&phase).filter(|p| HAND_PHASES.contains(p)) else {
                    return Err(Refusal::new(name, "phase", format!("{phase:?}"), allowed, "no such phase"));
                };
                let moves = matches!(p, Phase::Push | Phase::Pull);
                let lengths = match (moves, lengths_m) {
                    (true, Some(l)) => {
                        self.check_length(name, "lengths_m[0]", l[0])?;
                        self.check_length(name, "lengths_m[1]", l[1])?;
                        l
                    }
                    (true, None) => {
                        return Err(Refusal::new(name, "lengths_m", "missing", "[LA, LB] in m", "a move needs lengths"))
                    }
                    (false, Some(l)) => {
                        return Err(Refusal::new(
                            name,
                            "lengths_m",
                            format!("{l:?}"),
                            "none: this phase moves no tube",
                            "lengths given to a cup's phase",
                        ))
                    }
                    (false, None) => [f64::NAN; 2],
                };
                let holding = lock(&s.live).telemetry.as_ref().map(|(t, _)| observation(t).2);
                let prediction = Arc::clone(&lock(&s.prediction));
                let run = lock(&s.run).clone();
                self.phase_refusal(p, holding, &prediction, &run)
                    .map_err(|why| Refusal::new(name, "phase", p.name(), "a phase the interlock allows now", why))?;
                let e = evidence(p, prediction.body.as_ref());
                let after = (!e.safety_factor.is_nan()).then_some(e.safety_factor);
                let step = Move {
                    phase: p,
                    lengths_m: lengths,
                    rear_safety_factor: if p == Phase::ReleaseFront { after } else { None },
                    front_safety_factor: if p == Phase::ReleaseRear { after } else { None },
                };
                self.start_run(name, format!("stride {}", p.name()), vec![step], None)?;
                self.drop_plan();
                ok(json!({}))
            }
            Request::Execute { mode } => {
                self.may_drive(tab, name)?;
                if s.planning.load(Ordering::SeqCst) {
                    return Err(Refusal::new(
                        name,
                        "plan",
                        "being computed",
                        "a plan that has arrived",
                        "wait for the plan",
                    ));
                }
                let (moves, next, id) = match &*lock(&s.plan) {
                    Some(plan) if plan.next < plan.moves.len() => (plan.moves.clone(), plan.next, plan.id),
                    Some(_) => {
                        return Err(Refusal::new(name, "plan", "carried out", "a plan with steps left", "plan again"))
                    }
                    None => {
                        return Err(Refusal::new(
                            name,
                            "plan",
                            "none",
                            "a reached plan, planned from the robot's present state",
                            "plan a climb first (a manual command drops the plan)",
                        ))
                    }
                };
                let end = match mode {
                    Execute::Step => next + 1,
                    Execute::All => moves.len(),
                };
                self.start_run(name, "plan".into(), moves[next..end].to_vec(), Some((id, moves.len(), next)))?;
                ok(json!({}))
            }
            Request::Plan { scenario, goal_m, tolerance_m } => {
                self.may_drive(tab, name)?;
                self.idle(name)?;
                let goal = match (scenario, goal_m, tolerance_m) {
                    (Some(scenario), None, None) => self.scenario_goal(name, &scenario)?,
                    (None, Some(goal_m), Some(tolerance_m)) => {
                        for (i, x) in goal_m.iter().enumerate() {
                            self.check_point(name, &format!("goal_m[{i}]"), *x)?;
                        }
                        let most = stride::scenario::MAX_TOLERANCE_M;
                        if !(tolerance_m.is_finite() && tolerance_m > 0.0 && tolerance_m <= most) {
                            return Err(Refusal::new(
                                name,
                                "tolerance_m",
                                tolerance_m,
                                format!("a distance in (0, {most}] m"),
                                "bad tolerance",
                            ));
                        }
                        Goal { point_m: goal_m, tolerance_m }
                    }
                    _ => {
                        return Err(Refusal::new(
                            name,
                            "goal_m",
                            "with the scenario, or without a tolerance",
                            "a scenario alone, or goal_m with tolerance_m",
                            "a plan needs one goal",
                        ))
                    }
                };
                let held = self.rear_alone(name)?;
                let centre = held.rear_cup_m(&s.robot);
                let on = s.scene.surface_frame(centre).map_or(centre, |(p, _)| p);
                let start = Foothold { centre_m: on, direction_rad: held.unit.angle_rad };
                let shared = Arc::clone(s);
                s.planning.store(true, Ordering::SeqCst);
                *lock(&s.plan) = None;
                self.compute(name, later, move || {
                    // Cleared however the planner ends (a panic too).
                    struct Planned<'a>(&'a AtomicBool);
                    impl Drop for Planned<'_> {
                        fn drop(&mut self) {
                            self.0.store(false, Ordering::SeqCst);
                        }
                    }
                    let _planned = Planned(&shared.planning);
                    plan_reply(&shared, start, goal)
                })
                .inspect_err(|_| s.planning.store(false, Ordering::SeqCst))?;
                ok(json!({}))
            }
            Request::Reach { point_m } => {
                for (i, x) in point_m.iter().enumerate() {
                    self.check_point(name, &format!("point_m[{i}]"), *x)?;
                }
                let held = self.rear_alone(name)?;
                let shared = Arc::clone(s);
                self.compute(name, later, move || reach_reply(&shared, &held, point_m))?;
                ok(json!({}))
            }
            Request::Workspace {} => {
                let held = lock(&s.held).clone();
                let Some(held) = held else {
                    return Err(Refusal::new(name, "body", "unsolved", "a solved body", "the model has no body yet"));
                };
                let shared = Arc::clone(s);
                self.compute(name, later, move || workspace_reply(&shared, &held))?;
                ok(json!({}))
            }
        }
    }

    /// The goal of built-in scenario `scenario`, which must be set in the console's scene.
    fn scenario_goal(&self, name: &str, scenario: &str) -> Result<Goal, Refusal> {
        let builtin = stride::scenario::BUILTIN_SCENARIOS.map(|b| b.name);
        let Some(found) = builtin.iter().find(|b| **b == scenario) else {
            let value = format!("{:?}", crate::messages::excerpt(scenario, 40));
            return Err(Refusal::new(name, "scenario", value, builtin.join(", "), "no such built-in scenario"));
        };
        let scenario = stride::Scenario::builtin(found)
            .map_err(|e| Refusal::new(name, "scenario", found, builtin.join(", "), format!("cannot read it: {e}")))?;
        if scenario.scene != self.shared.scene {
            return Err(Refusal::new(
                name,
                "scenario",
                found,
                format!("a scenario set in the console's scene ({})", self.shared.scene.name),
                format!("its scene is {}", scenario.scene.name),
            ));
        }
        Ok(scenario.goal)
    }

    /// Refuses a tab that does not drive.
    fn may_drive(&self, tab: u64, name: &str) -> Result<(), Refusal> {
        match *lock(&self.shared.driver) {
            Some(d) if d == tab => Ok(()),
            Some(d) => Err(Refusal::new(
                name,
                "control",
                format!("tab {tab}"),
                format!("the driving tab {d}"),
                format!("tab {d} drives; this tab watches"),
            )),
            None => Err(Refusal::new(
                name,
                "control",
                format!("tab {tab}"),
                "the tab that took control",
                "no tab drives: take control first",
            )),
        }
    }

    /// Drops the previewed plan after a manual command: a plan is carried
    /// out only from the state it was planned in.
    fn drop_plan(&self) {
        *lock(&self.shared.plan) = None;
    }

    /// Refuses while a step or a plan runs.
    fn idle(&self, name: &str) -> Result<(), Refusal> {
        idle_run(name, &lock(&self.shared.run))
    }

    /// A tube length within the robot file's limits.
    fn check_length(&self, name: &str, field: &str, l: f64) -> Result<(), Refusal> {
        let (lo, hi) = (self.shared.robot.limits.tube_length_min_m, self.shared.robot.limits.tube_length_max_m);
        if (lo..=hi).contains(&l) {
            Ok(())
        } else {
            Err(Refusal::new(
                name,
                field,
                l,
                format!("a length in [{lo}, {hi}] m (the robot file's limits)"),
                "out of range",
            ))
        }
    }

    /// A coordinate within a scene's bounds.
    fn check_point(&self, name: &str, field: &str, x: f64) -> Result<(), Refusal> {
        let m = leech::scene::MAX_COORDINATE_M;
        if x.is_finite() && x.abs() <= m {
            Ok(())
        } else {
            Err(Refusal::new(name, field, x, format!("a coordinate within +-{m} m"), "out of range"))
        }
    }

    /// The equilibrium, when the rear cup alone holds (where a stride or a
    /// reach starts).
    fn rear_alone(&self, name: &str) -> Result<Held, Refusal> {
        match lock(&self.shared.held).clone() {
            Some(held) if matches!(held.hold, Hold::Rear(_)) => Ok(held),
            Some(held) => Err(Refusal::new(
                name,
                "holding",
                held.hold.name(),
                "the rear cup alone holding",
                "a climb and a reach start from the rear cup alone",
            )),
            None => Err(Refusal::new(name, "body", "unsolved", "a solved body", "the model has no body yet")),
        }
    }

    /// Runs `job` on a thread of its own, one at a time, and hands its reply to `later`.
    fn compute(&self, name: &str, later: Later, job: impl FnOnce() -> Reply + Send + 'static) -> Result<(), Refusal> {
        let s = Arc::clone(&self.shared);
        if s.computing.compare_exchange(false, true, Ordering::SeqCst, Ordering::SeqCst).is_err() {
            return Err(Refusal::new(name, "busy", "computing", "one computation at a time", "wait for the last one"));
        }
        let spawned = std::thread::Builder::new().name("console-compute".into()).spawn(move || {
            // A panic in a solve must not leave the console busy for ever.
            let reply = std::panic::catch_unwind(std::panic::AssertUnwindSafe(job))
                .unwrap_or_else(|_| json!({ "type": "error", "message": "the computation failed" }));
            s.computing.store(false, Ordering::SeqCst);
            later(reply);
        });
        spawned.map(|_| ()).map_err(|e| {
            self.shared.computing.store(false, Ordering::SeqCst);
            Refusal::new(name, "thread", e, "a thread", "cannot start the computation")
        })
    }

    /// Starts carrying out `moves` on the executor's thread (`plan`: the
    /// plan's id, its number of steps and where they start in it: that
    /// plan's progress they advance).
    fn start_run(
        &self,
        name: &str,
        what: String,
        moves: Vec<Move>,
        plan: Option<(u64, usize, usize)>,
    ) -> Result<(), Refusal> {
        let s = Arc::clone(&self.shared);
        {
            let mut run = lock(&s.run);
            idle_run(name, &run)?;
            let (next_step, steps) = plan.map_or((0, 0), |(_, steps, next)| (next, steps));
            *run = Run { busy: true, what: what.clone(), next_step, steps, error: None };
        }
        s.cancel.store(false, Ordering::SeqCst);
        let spawned = std::thread::Builder::new().name("console-run".into()).spawn({
            let s = Arc::clone(&s);
            move || {
                let error = run_moves(&s, &moves, plan.map(|(id, _, next)| (id, next))).err();
                let mut run = lock(&s.run);
                run.busy = false;
                run.error = error;
            }
        });
        spawned.map(|_| ()).map_err(|e| {
            lock(&s.run).busy = false;
            Refusal::new(name, "thread", e, "a thread", "cannot start the run")
        })
    }
}

/// Carries out `moves` behind the executor's interlock, one step at a
/// time so that a stop is heard between steps.
fn run_moves(s: &Shared, moves: &[Move], plan: Option<(u64, usize)>) -> Result<(), String> {
    let mut ex = Executor::new(&s.link, s.robot.cup.min_safety_factor, executor::Options::default())
        .map_err(|e| e.to_string())?;
    let first = plan.map_or(0, |(_, i)| i);
    for (k, step) in moves.iter().enumerate() {
        if s.cancel.load(Ordering::SeqCst) {
            return Err("stopped".into());
        }
        if !matches!(step.phase, Phase::Start | Phase::Push | Phase::Pull) {
            live_interlock(s, step.phase).map_err(|why| {
                format!("step {} ({}) refused by the console's interlock: {why}", first + k, step.phase.name())
            })?;
        }
        if matches!(step.phase, Phase::Start | Phase::Push | Phase::Pull) {
            let [la, lb] = step.lengths_m.map(|l| (l * 1e6).round() as i32);
            lock(&s.live).commanded_um = Some([la, lb, lb]);
        }
        ex.step(first + k, step).map_err(|e| {
            if s.cancel.load(Ordering::SeqCst) {
                format!("stopped: {e}")
            } else {
                e.to_string()
            }
        })?;
        if let Some((id, i)) = plan {
            if let Some(plan) = lock(&s.plan).as_mut().filter(|p| p.id == id) {
                plan.next = i + k + 1;
            }
            lock(&s.run).next_step = i + k + 1;
        }
    }
    Ok(())
}

/// Plans the climb and keeps it for [`Request::Execute`] if it reaches the goal.
fn plan_reply(s: &Shared, start: Foothold, goal: Goal) -> Reply {
    let deadline = leech::budget::Deadline::after(Duration::from_secs(PLAN_SECONDS));
    let options = stride::PlanOptions { deadline, ..Default::default() };
    let plan = match stride::plan(&s.robot, &s.scene, start, goal, &options) {
        Ok(plan) => plan,
        Err(e) => return json!({ "type": "plan", "status": "refused", "reason": e.to_string(), "steps": [] }),
    };
    let n = plan.steps.len();
    let steps: Vec<_> = plan
        .steps
        .iter()
        .enumerate()
        .map(|(i, step)| {
            json!({
                "phase": step.phase.name(),
                "lengths_m": step.lengths_m,
                "caption": leech_plot::climb::caption(step, plan.strides, i, n),
                "body": model::drawing(&s.robot, &s.scene, &step.held),
            })
        })
        .collect();
    let reached = plan.status == stride::Status::Reached;
    let id = s.plan_ids.fetch_add(1, Ordering::SeqCst) + 1;
    *lock(&s.plan) = reached.then(|| PlanState { id, moves: executor::moves(&plan), next: 0 });
    json!({
        "type": "plan",
        "status": plan.status,
        "reason": plan.reason.as_ref().map(|r| r.detail.clone()),
        "strides": plan.strides,
        "duration_s": plan.duration_s(),
        "goal": { "point_m": goal.point_m, "tolerance_m": goal.tolerance_m },
        "steps": steps,
    })
}

/// The lengths that put the front cup on the surface nearest `point`, and
/// the body they predict, the rear hold kept.
fn reach_reply(s: &Shared, held: &Held, point: Vec2) -> Reply {
    let fail = |why: String| json!({ "type": "reach", "status": "refused", "reason": why });
    let Some((on, angle)) = s.scene.surface_frame(point) else { return fail("the scene has no surface".into()) };
    let unit = held.unit;
    let endpoint = stance::front_pose_for_cup(&s.robot, on, angle);
    let (lo, hi) = (s.robot.limits.tube_length_min_m, s.robot.limits.tube_length_max_m);
    let reacher = s
        .robot
        .with_base_angle(unit.angle_rad.to_degrees())
        .map_err(leech::inverse_statics::ReachError::from)
        .and_then(|r| {
            let grid = leech::sweep::Grid::new(lo, hi, WORKSPACE_STEP_M)?;
            leech::inverse_statics::Reacher::new(&r, grid, leech::budget::Deadline::none())
        });
    let reacher = match reacher {
        Ok(r) => r,
        Err(e) => return fail(e.to_string()),
    };
    let target = [endpoint.point_m[0] - unit.point_m[0], endpoint.point_m[1] - unit.point_m[1]];
    let answer = match reacher.reach(target, Some(angle)) {
        Ok(answer) => answer,
        Err(e) => return fail(e.to_string()),
    };
    let body =
        stance::solve_among(&s.robot, answer.lengths_m, Hold::Rear(unit), &s.scene, &Solver::default(), FreeCups::Rest);
    let (body, error) = match body {
        Ok(b) => (Some(model::drawing(&s.robot, &s.scene, &b)), None),
        Err(e) => (None, Some(e.to_string())),
    };
    json!({
        "type": "reach",
        "status": answer.status,
        "surface_m": on,
        "surface_angle_rad": angle,
        "lengths_m": answer.lengths_m,
        "error_m": answer.error_m,
        "angle_error_rad": answer.angle_error_rad,
        "body": body,
        "reason": error,
    })
}

/// The endpoints the tubes can reach from where the driving unit is (no
/// contacts), cached per unit angle.
fn workspace_reply(s: &Shared, held: &Held) -> Reply {
    use rayon::prelude::*;
    let unit = held.unit;
    let key = (unit.angle_rad * 100.0).round() as i64;
    let cached = lock(&s.workspace).as_ref().filter(|(k, _)| *k == key).map(|(_, p)| Arc::clone(p));
    let relative = match cached {
        Some(points) => points,
        None => {
            let (lo, hi) = (s.robot.limits.tube_length_min_m, s.robot.limits.tube_length_max_m);
            let robot = match s.robot.with_base_angle(unit.angle_rad.to_degrees()) {
                Ok(r) => r,
                Err(e) => return json!({ "type": "workspace", "reason": e.to_string(), "points_m": [] }),
            };
            let grid = leech::sweep::Grid::new(lo, hi, WORKSPACE_STEP_M).map(|g| g.values()).unwrap_or_default();
            let pairs: Vec<(f64, f64)> = grid.iter().flat_map(|&a| grid.iter().map(move |&b| (a, b))).collect();
            let points: Vec<Vec2> = pairs
                .par_iter()
                .filter_map(|&(la, lb)| {
                    let body = robot.body(la, lb).ok()?;
                    let eq = body.solve(&Solver::default()).ok()?;
                    Some(body.endpoint(&eq.q))
                })
                .collect();
            let points = Arc::new(points);
            *lock(&s.workspace) = Some((key, Arc::clone(&points)));
            points
        }
    };
    let points: Vec<Vec2> = relative.iter().map(|p| [p[0] + unit.point_m[0], p[1] + unit.point_m[1]]).collect();
    json!({ "type": "workspace", "points_m": points })
}
