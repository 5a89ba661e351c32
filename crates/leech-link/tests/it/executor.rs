//! The stride executor: a planned crawl carried out on the simulated body
//! over a pseudo-terminal, the interlock refusing an edited plan before
//! anything is sent, and a link cut in the middle of a push.
//!
//! The crawl takes about 50 s of tube motion at the paper's 20 mm/s; these
//! tests run the simulated tubes at up to 40 mm/s (`max_tube_speed_mm_s`, the
//! simulation's only change) so that it takes half of that (faster, the position loop tuned for 20 mm/s overshoots the 50 mm limit by more than its 2 mm margin at the end of a pull).

use std::sync::OnceLock;
use std::time::{Duration, Instant};

use leech::robot::Robot;
use leech::stride::{self, Phase, Plan, PlanOptions, Scenario, Status, StrideError};
use leech_link::body::BodyCups;
use leech_link::executor::{ExecError, Executor, Options};
use leech_link::host::Link;
use leech_link::pty::PtyDevice;
use leech_link::sim::{Cups, Faults, Sim, SimConfig};
use leech_protocol::message::Cup;

use super::{configure, options, wait_until};

/// The tubes' top speed in these tests (mm/s).
const FAST_MM_S: f64 = 40.0;

/// The built-in crawl and its plan, planned once for all the tests.
fn crawl() -> &'static (Scenario, Plan) {
    static CRAWL: OnceLock<(Scenario, Plan)> = OnceLock::new();
    CRAWL.get_or_init(|| {
        let scenario = Scenario::builtin("crawl-floor").expect("a built-in scenario");
        let plan =
            stride::plan(&Robot::builtin(), &scenario.scene, scenario.start, scenario.goal, &PlanOptions::default())
                .expect("a plan");
        assert_eq!(plan.status, Status::Reached, "{:?}", plan.reason);
        (scenario, plan)
    })
}

/// A simulated robot at the plan's start lengths, fast, with `cups`; linked,
/// configured, its rear cup holding.
fn robot_at_start(plan: &Plan, cups: Box<dyn Cups>) -> (PtyDevice, Link, SimConfig) {
    let [la, lb] = plan.steps[0].lengths_m.map(|l| (l * 1e6).round() as i32);
    let config = SimConfig { initial_lengths_um: [la, lb, lb], max_tube_speed_mm_s: FAST_MM_S, ..SimConfig::default() };
    let device = PtyDevice::spawn(Sim::with_cups(config, cups)).expect("a pseudo-terminal");
    let link = Link::open(device.path(), options()).expect("handshake");
    configure(&link, &config, 20);
    link.pump(Cup::Rear, true).expect("rear pump on");
    assert!(wait_until(Duration::from_secs(3), || device.state().holding[0]), "the rear cup holds on its foothold");
    (device, link, config)
}

#[test]
fn a_planned_crawl_runs_end_to_end_on_the_simulated_body() {
    let (scenario, plan) = crawl();
    let robot = Robot::builtin();
    let body = BodyCups::new(robot.clone(), scenario.scene.clone(), scenario.start);
    let (device, link, _) = robot_at_start(plan, Box::new(body.clone()));
    let mut executor = Executor::new(&link, robot.cup.min_safety_factor, Options::default()).expect("executor");
    let mut done = Vec::new();
    let started = Instant::now();
    executor
        .run(&leech_link::executor::moves(plan), |step| done.push((step.index, step.phase)))
        .unwrap_or_else(|e| panic!("{e}"));
    let expected: Vec<(usize, Phase)> = plan.steps.iter().map(|s| s.phase).enumerate().collect();
    assert_eq!(done, expected, "every step completed, in order");
    assert!(started.elapsed() < Duration::from_secs(60), "took {:?}", started.elapsed());

    let last = plan.steps.last().expect("steps");
    let planned = last.held.rear_cup_m(&robot);
    let pose = body.pose().expect("the body's equilibrium");
    let off = ((pose.rear_cup_m[0] - planned[0]).powi(2) + (pose.rear_cup_m[1] - planned[1]).powi(2)).sqrt();
    assert!(off < 0.005, "rear cup at {:?}, planned at {planned:?}: {off} m off", pose.rear_cup_m);
    let state = device.state();
    assert_eq!(state.holding, [true, false], "the crawl ends on the rear cup");
    assert_eq!(state.faults, 0, "no fault raised");
}

#[test]
fn a_plan_releasing_the_last_holding_cup_is_refused_before_anything_is_sent() {
    let (_, plan) = crawl();
    // The front cup never attaches: the rear release would drop the robot.
    let mut edited = plan.clone();
    let attach = edited.steps.iter().position(|s| s.phase == Phase::AttachFront).expect("an attach");
    edited.steps.remove(attach);
    let (device, link, _) = robot_at_start(plan, Box::new(leech_link::sim::AlwaysSealed));
    let before = device.state();
    let mut executor = Executor::new(&link, 1.5, Options::default()).expect("executor");
    let error =
        executor.run(&leech_link::executor::moves(&edited), |step| panic!("no step may run: {step:?}")).unwrap_err();
    assert!(
        matches!(
            error,
            ExecError::Interlock {
                index,
                phase: Phase::ReleaseRear,
                source: StrideError::LastHold { cup: stride::Cup::Rear }
            } if index == attach
        ),
        "{error}"
    );
    assert!(error.to_string().starts_with(&format!("step {attach} (release_rear): ")), "{error}");
    let after = device.state();
    assert_eq!(after.targets_um, [None; 3], "no tube was sent anywhere");
    assert_eq!(after.pumps, before.pumps, "no pump was touched");
    assert_eq!(after.counters.rx_frames, before.counters.rx_frames + 1, "only the telemetry period was sent");
}

#[test]
fn a_link_cut_mid_push_stops_and_names_the_step() {
    let (_, plan) = crawl();
    let (device, link, config) = robot_at_start(plan, Box::new(leech_link::sim::AlwaysSealed));
    let push = plan.steps.iter().position(|s| s.phase == Phase::Push).expect("a push");
    let start_um = f64::from(config.initial_lengths_um[0]);
    let error = std::thread::scope(|scope| {
        let running = scope.spawn(|| {
            let mut executor = Executor::new(&link, 1.5, Options::default()).expect("executor");
            executor.run(&leech_link::executor::moves(plan), |_| {})
        });
        let moving = wait_until(Duration::from_secs(10), || {
            let l1 = device.state().lengths_um[0];
            (l1 - start_um).abs() > 5_000.0
        });
        assert!(moving, "the push started");
        device.set_faults(Faults { cut: true, ..Faults::default() });
        running.join().expect("no panic").unwrap_err()
    });
    assert!(
        matches!(error, ExecError::LinkLost { index, phase: Phase::Push, .. } | ExecError::Link { index, phase: Phase::Push, .. } if index == push),
        "{error}"
    );
    // The device stops its motors itself once the link is lost (500 ms).
    assert!(wait_until(Duration::from_secs(2), || device.state().targets_um == [None; 3]), "motors stopped");
    let state = device.state();
    assert_eq!(state.duty_permille, [0; 3], "no duty");
    assert_eq!(state.pumps, [true, false], "the pumps as they were: the rear cup keeps holding");
    assert!(state.holding[0], "the rear cup holds");
}
