//! `leech sim-robot` and `leech drive`: flags resolved into the simulated
//! robot's configuration and faults, and the controller's tube settings.

use std::path::{Path, PathBuf};
use std::time::Duration;

use leech::error::{quoted, Num};
use leech::prelude::Robot;
use leech::scene::Scene;
use leech::stride::Phase;
use leech::stride::{Foothold, Goal, Scenario};
use leech_link::executor::Move;
use leech_link::sim::{Faults, SimConfig};
use leech_protocol::message::{Cup, Faults as FaultBits, Tube, TubeConfig};

use super::tuned;
use crate::failure::Failure;
use crate::flags::{CupArg, DriveAction, DriveArgs, OnOff, SimRobotArgs};

/// `leech sim-robot`: the device to simulate, its faults and how long to run.
pub struct SimRobot {
    pub config: SimConfig,
    /// The robot, the scene and the rear cup's start of the simulated body
    /// (None: every cup seals).
    pub body: Option<(Robot, Scene, Foothold)>,
    pub faults: Faults,
    /// How often to print the state (None: never).
    pub status_every: Option<Duration>,
    /// How long to run (None: until interrupted).
    pub duration: Option<Duration>,
}

/// `leech drive`: the port, the tubes' settings and the action.
pub struct Drive {
    pub port: PathBuf,
    /// The robot's minimum safety factor (the interlock's, for `run`).
    pub min_safety_factor: f64,
    pub tubes: [TubeConfig; 3],
    pub action: Action,
    pub json: bool,
}

/// A `leech drive` action with its values checked.
pub enum Action {
    Status,
    Lengths([i32; 3]),
    Jog(Tube, i32),
    Pump(Cup, bool),
    Stop,
    /// Clear these latched faults.
    ClearFaults(FaultBits),
    /// Carry out a plan's moves.
    Run(Run),
}

/// What `leech drive run` carries out.
pub enum Run {
    /// One phase by hand (`leech drive stride`).
    Phase(Move),
    /// A plan read from `leech climb --json`.
    Moves(Vec<Move>),
    /// A scenario to plan first, for the robot.
    Scenario(Box<Robot>, Box<Scenario>),
}

/// A positive number of seconds within a day, as a duration.
fn seconds(flag: &str, s: f64) -> Result<Duration, Failure> {
    if s.is_finite() && s > 0.0 && s <= 86_400.0 {
        Ok(Duration::from_secs_f64(s))
    } else {
        Err(Failure::Input(format!("{flag}: got {}, expected seconds in (0, 86400]", Num(s))))
    }
}

pub(super) fn sim_robot(a: SimRobotArgs) -> Result<SimRobot, Failure> {
    let robot = tuned(&a.robot, Ok)?;
    let config = leech_link::settings::sim_config(&robot);
    let faults = a.faults.as_deref().map(faults).transpose()?.unwrap_or_default();
    let status_every = if a.status_every == 0.0 { None } else { Some(seconds("--status-every", a.status_every)?) };
    let duration = a.duration.map(|s| seconds("--duration", s)).transpose()?;
    let body = place(&robot, a.scenario.as_deref(), a.scene.as_deref())?.map(|p| (robot, p.scene, p.start));
    Ok(SimRobot { config, body, faults, status_every, duration })
}

/// Where a simulated robot is: a scene, its rear cup's start, and the
/// scenario's goal.
pub struct Place {
    pub scene: Scene,
    pub start: Foothold,
    pub goal: Option<Goal>,
}

/// The place `--scenario` or `--scene` names, checked for `robot` (None without either).
pub(super) fn place(robot: &Robot, scenario: Option<&Path>, scene: Option<&Path>) -> Result<Option<Place>, Failure> {
    Ok(Some(match (scenario, scene) {
        (Some(path), _) => {
            let (scenario, _) = super::climb::load_scenario(path, "--scenario")?;
            scenario.check_start(robot)?;
            Place { scene: scenario.scene, start: scenario.start, goal: Some(scenario.goal) }
        }
        (None, Some(path)) => {
            let (scene, _) = super::holds::load_scene(path, "--scene")?;
            let Some(start) = scene.start else {
                return Err(Failure::Input(format!(
                    "--scene: '{}' has no [start] table, expected a scene with one (or a --scenario)",
                    path.display()
                )));
            };
            let start = Foothold { centre_m: start.rear_cup_m, direction_rad: start.direction_rad };
            Place { scene, start, goal: None }
        }
        (None, None) => return Ok(None),
    }))
}

/// The `--faults` spec: `drop=P,corrupt=P,delay=S,cut,vacuum-loss=rear|front,stall=1|2|3,lose-fault-reports,seed=N`.
fn faults(spec: &str) -> Result<Faults, Failure> {
    let mut f = Faults::default();
    let bad = |item: &str, allowed: &str| Failure::Input(format!("--faults: got {}, expected {allowed}", quoted(item)));
    let rate = |item: &str, v: &str| match v.parse::<f64>() {
        Ok(p) if (0.0..=1.0).contains(&p) => Ok(p),
        _ => Err(bad(item, "a probability in [0, 1]")),
    };
    for item in spec.split(',').map(str::trim).filter(|i| !i.is_empty()) {
        let (key, value) = item.split_once('=').unwrap_or((item, ""));
        match key {
            "drop" => f.drop_rate = rate(item, value)?,
            "corrupt" => f.corrupt_rate = rate(item, value)?,
            "delay" => {
                f.delay_s = match value.parse::<f64>() {
                    Ok(s) if (0.0..=10.0).contains(&s) => s,
                    _ => return Err(bad(item, "a delay in s within [0, 10]")),
                }
            }
            "cut" if value.is_empty() => f.cut = true,
            "lose-fault-reports" if value.is_empty() => f.lose_fault_reports = true,
            "vacuum-loss" => match value {
                "rear" => f.vacuum_loss[0] = true,
                "front" => f.vacuum_loss[1] = true,
                _ => return Err(bad(item, "vacuum-loss=rear or vacuum-loss=front")),
            },
            "stall" => match value.parse::<usize>() {
                Ok(t @ 1..=3) => f.stalled[t - 1] = true,
                _ => return Err(bad(item, "stall=1, 2 or 3")),
            },
            "seed" => f.seed = value.parse().map_err(|_| bad(item, "a whole number"))?,
            _ => return Err(bad(
                item,
                "drop=P, corrupt=P, delay=S, cut, vacuum-loss=rear|front, stall=1|2|3, lose-fault-reports or seed=N, \
                     comma-separated",
            )),
        }
    }
    Ok(f)
}

pub(super) fn drive(a: DriveArgs) -> Result<Drive, Failure> {
    let robot = tuned(&a.robot, Ok)?;
    let um = |m: f64| (m * 1e6).round() as i32;
    let (lo, hi) = (robot.limits.tube_length_min_m, robot.limits.tube_length_max_m);
    let action = match a.action {
        DriveAction::Status => Action::Status,
        DriveAction::Lengths { lengths } => {
            for (i, l) in lengths.iter().enumerate() {
                if !(lo..=hi).contains(l) {
                    return Err(Failure::Input(format!(
                        "lengths: got L{} = {l} m, expected a length within the robot's limits [{lo}, {hi}] m",
                        i + 1
                    )));
                }
            }
            Action::Lengths(lengths.map(um))
        }
        DriveAction::Jog { tube, mm } => {
            let tube = match tube {
                1 => Tube::L1,
                2 => Tube::L2,
                3 => Tube::L3,
                _ => return Err(Failure::Input(format!("jog: got tube {tube}, expected 1, 2 or 3"))),
            };
            let most = (hi - lo) * 1e3;
            if !(mm.is_finite() && mm.abs() <= most) {
                return Err(Failure::Input(format!(
                    "jog: got {} mm, expected at most {} mm either way",
                    Num(mm),
                    Num(most)
                )));
            }
            Action::Jog(tube, (mm * 1e3).round() as i32)
        }
        DriveAction::Pump { cup, state } => Action::Pump(
            match cup {
                CupArg::Rear => Cup::Rear,
                CupArg::Front => Cup::Front,
            },
            state == OnOff::On,
        ),
        DriveAction::Stop => Action::Stop,
        DriveAction::ClearFaults { faults } => Action::ClearFaults(fault_set(&faults)?),
        DriveAction::Stride { phase, lengths, safety_factor } => {
            let phase = Phase::from_name(&phase).filter(|p| *p != Phase::Start).ok_or_else(|| {
                Failure::Input(format!(
                    "stride: got '{phase}', expected push, attach_front, release_rear, pull, attach_rear or release_front"
                ))
            })?;
            let moves = matches!(phase, Phase::Push | Phase::Pull);
            let lengths_m = match (moves, lengths) {
                (true, Some(l)) if l.iter().all(|x| (lo..=hi).contains(x)) => l,
                (true, Some(l)) => {
                    return Err(Failure::Input(format!(
                        "--lengths: got {}, {}, expected lengths within the robot's limits [{}, {}] m",
                        Num(l[0]),
                        Num(l[1]),
                        Num(lo),
                        Num(hi)
                    )))
                }
                (true, None) => return Err(Failure::Input(format!("stride {}: give --lengths LA,LB", phase.name()))),
                (false, Some(_)) => return Err(Failure::Input(format!("--lengths: {} moves no tube", phase.name()))),
                (false, None) => [f64::NAN; 2],
            };
            let (rear_safety_factor, front_safety_factor) = match phase {
                Phase::ReleaseRear => (None, Some(evidence(safety_factor)?)),
                Phase::ReleaseFront => (Some(evidence(safety_factor)?), None),
                _ => (None, None),
            };
            Action::Run(Run::Phase(Move { phase, lengths_m, rear_safety_factor, front_safety_factor }))
        }
        DriveAction::Run { scenario: Some(scenario), .. } => {
            let (scenario, _) = super::climb::load_scenario(&scenario, "--scenario")?;
            scenario.check_start(&robot)?;
            scenario.check_goal()?;
            Action::Run(Run::Scenario(Box::new(robot.clone()), Box::new(scenario)))
        }
        DriveAction::Run { plan: Some(plan), .. } => Action::Run(Run::Moves(plan_moves(&plan, [lo, hi])?)),
        DriveAction::Run { .. } => return Err(Failure::Input("run: give PLAN.json or --scenario".into())),
    };
    let tubes = leech_link::settings::tube_configs(&robot);
    Ok(Drive { port: a.port, min_safety_factor: robot.cup.min_safety_factor, tubes, action, json: a.json })
}

/// Most steps a plan file may give `leech drive run`: far more than any
/// climb's (a stride has six), few enough to check at once.
pub const MAX_PLAN_STEPS: usize = 10_000;

/// The moves of a plan written by `leech climb --json`: a reached plan,
/// each step's phase known and its lengths within the robot's limits.
fn plan_moves(path: &std::path::Path, [lo, hi]: [f64; 2]) -> Result<Vec<Move>, Failure> {
    let text = leech::files::read_text(path, "run", leech::files::PLAN_FILE)?;
    let name = quoted(&path.to_string_lossy());
    let bad = |what: String| Failure::Input(format!("run: {name}: {what}"));
    let v: serde_json::Value = serde_json::from_str(&text)
        .map_err(|e| bad(format!("not JSON ({e}), expected a plan from leech climb --json")))?;
    if v["status"] != "reached" {
        return Err(bad(format!(
            "status {}, expected a plan that reached its goal (\"reached\")",
            quoted(&v["status"].to_string())
        )));
    }
    let steps = v["steps"].as_array().ok_or_else(|| bad("no steps, expected a plan from leech climb --json".into()))?;
    if steps.is_empty() || steps.len() > MAX_PLAN_STEPS {
        return Err(bad(format!("steps: got {}, expected 1 to {MAX_PLAN_STEPS} steps", steps.len())));
    }
    steps
        .iter()
        .enumerate()
        .map(|(i, step)| {
            let phase = step["phase"].as_str().and_then(Phase::from_name).ok_or_else(|| {
                bad(format!(
                    "steps[{i}].phase: got {}, expected a phase name (push, attach_front, ...)",
                    quoted(&step["phase"].to_string())
                ))
            })?;
            match step["lengths_m"].as_array() {
                Some(lengths) if lengths.len() == 2 => {}
                _ => {
                    return Err(bad(format!(
                        "steps[{i}].lengths_m: got {}, expected [LA, LB]: two lengths (m) within the robot's limits [{}, {}] m",
                        quoted(&step["lengths_m"].to_string()),
                        Num(lo),
                        Num(hi)
                    )))
                }
            }
            let length = |k: usize| {
                step["lengths_m"][k].as_f64().filter(|l| (lo..=hi).contains(l)).ok_or_else(|| {
                    bad(format!(
                        "steps[{i}].lengths_m[{k}]: got {}, expected a length within the robot's limits [{}, {}] m",
                        quoted(&step["lengths_m"][k].to_string()),
                        Num(lo),
                        Num(hi)
                    ))
                })
            };
            let factor = |cup: &str| step["safety_factor"][cup].as_f64();
            Ok(Move {
                phase,
                lengths_m: [length(0)?, length(1)?],
                rear_safety_factor: factor("rear"),
                front_safety_factor: factor("front"),
            })
        })
        .collect()
}

/// The faults `clear-faults` names, comma-separated, or `all`.
fn fault_set(spec: &str) -> Result<FaultBits, Failure> {
    let names = [
        ("link-lost", FaultBits::LINK_LOST),
        ("motor-stall", FaultBits::MOTOR_STALL),
        ("vacuum-lost", FaultBits::VACUUM_LOST),
        ("limit-hit", FaultBits::LIMIT_HIT),
        ("watchdog-reset", FaultBits::WATCHDOG_RESET),
        ("brownout-reset", FaultBits::BROWNOUT_RESET),
    ];
    let allowed =
        "link-lost, motor-stall, vacuum-lost, limit-hit, watchdog-reset, brownout-reset (comma-separated) or all";
    if spec.trim() == "all" {
        return Ok(names.iter().fold(FaultBits::default(), |set, (_, bit)| set.union(*bit)));
    }
    let mut set = FaultBits::default();
    for item in spec.split(',').map(str::trim) {
        // The protocol's own names (motor_stall) are accepted too.
        let bit = names.iter().find(|(name, _)| *name == item.replace('_', "-")).map(|(_, bit)| *bit);
        match bit {
            Some(bit) => set = set.union(bit),
            None => return Err(Failure::Input(format!("clear-faults: got {}, expected {allowed}", quoted(item)))),
        }
    }
    Ok(set)
}

/// A release's evidence: the holding cup's safety factor after it.
fn evidence(given: Option<f64>) -> Result<f64, Failure> {
    match given {
        Some(f) if f.is_finite() && f > 0.0 => Ok(f),
        Some(f) => Err(Failure::Input(format!("--safety-factor: got {}, expected a positive number", Num(f)))),
        None => Err(Failure::Input(
            "stride release: give --safety-factor SF, the holding cup's after the release (leech shape --hold)".into(),
        )),
    }
}
