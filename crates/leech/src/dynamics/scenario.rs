//! Simulations of the robot's body as the command line runs them: start,
//! actuation, gravity ramp, samples, rest.

use super::{Integrator, Motion, Simulator, StepError};
use crate::body::Body;

/// Most steps one simulation takes.
pub const MAX_STEPS: usize = 10_000_000;

/// The implicit scheme's default step (s), never longer than the run
/// itself: the step the energy bound of the [`crate::dynamics`] module doc is tested
/// at, far beyond the explicit scheme's stability limit.
pub const IMPLICIT_STEP_S: f64 = 5e-3;

/// How the tubes move during a simulation.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Actuation {
    /// Lengths held.
    Hold,
    /// Lengths switched at once to `to` (m) at the start.
    Step {
        /// New lengths LA, LB (m).
        to: [f64; 2],
    },
    /// Both tubes fed towards `to` (m) at `speed` (m/s) each, as the motors do.
    Feed {
        /// Final lengths LA, LB (m).
        to: [f64; 2],
        /// Feeding speed (m/s).
        speed: f64,
    },
}

/// Where a simulation starts.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Start {
    /// The unloaded (g = 0) equilibrium at rest, gravity then switched on (the paper's method).
    Unloaded,
    /// The static equilibrium with gravity, at rest.
    Static,
}

/// Settings of [`simulate`].
#[derive(Clone, Debug, PartialEq)]
pub struct SimulationOptions {
    /// Time-stepping scheme.
    pub integrator: Integrator,
    /// Time step (s); `None` picks [`IMPLICIT_STEP_S`] (at most the
    /// duration) for the implicit scheme and [`Simulator::stable_step`] for
    /// the others.
    pub dt: Option<f64>,
    /// Simulated time (s); the longest run when stopping at rest.
    pub duration: f64,
    /// Stop when at rest (after the actuation and the gravity ramp end).
    pub until_rest: bool,
    /// Gravity raised linearly over this time (s); 0 for all at once.
    pub gravity_ramp: f64,
    /// Interval between recorded samples (s).
    pub sample_interval: f64,
    /// At rest when every rate is below this (rad/s), see [`Simulator::at_rest`].
    pub rest_rate: f64,
    /// When the run stops ([`SimulationError::Stopped`]): checked by the
    /// starting solve and at every time step.
    pub deadline: crate::budget::Deadline,
}

/// A recorded instant.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
pub struct Sample {
    /// Time (s).
    pub time_s: f64,
    /// Tube lengths (m).
    pub lengths_m: [f64; 2],
    /// Chain A's angles (rad).
    pub angles_a_rad: Vec<f64>,
    /// Chain B's angles (rad).
    pub angles_b_rad: Vec<f64>,
    /// Chain A's centre line (m).
    pub points_a_m: Vec<[f64; 2]>,
    /// Chain B's centre line (m).
    pub points_b_m: Vec<[f64; 2]>,
    /// Endpoint (m).
    pub endpoint_m: [f64; 2],
    /// Kinetic energy (J).
    pub kinetic_j: f64,
    /// Potential energy (J).
    pub potential_j: f64,
    /// Largest constraint violation (m or rad).
    pub violation: f64,
}

/// A finished simulation.
#[derive(Clone, Debug, PartialEq)]
pub struct Simulation {
    /// Recorded samples, first at t = 0, last at the end.
    pub samples: Vec<Sample>,
    /// Time when the body came to rest (s), if it did.
    pub time_to_rest: Option<f64>,
    /// Steps taken.
    pub steps: usize,
    /// The step used (s).
    pub dt: f64,
    /// Largest constraint violation over the run (m or rad).
    pub max_violation: f64,
    /// Largest increase of the total energy from one sample to the next
    /// while the inputs are settled (J): see [`energy_gain`]. A damped
    /// body loses energy; a gain above round-off says the step is too long
    /// for the motion (see the module's energy balance). `None` if no two
    /// samples were taken with the inputs settled.
    pub max_energy_gain_j: Option<f64>,
}

/// The largest increase of kinetic plus potential energy (J) between
/// consecutive samples taken with the inputs settled: the lengths those of
/// the last sample (the feeding done) and gravity fully on (at or after
/// `gravity_ramp`, s). While the inputs move, the motors and the rising
/// gravity do work, and the energy may rise legitimately.
pub fn energy_gain(samples: &[Sample], gravity_ramp: f64) -> Option<f64> {
    let last = samples.last()?.lengths_m;
    let settled = |s: &Sample| s.lengths_m == last && s.time_s >= gravity_ramp;
    samples
        .windows(2)
        .filter(|w| settled(&w[0]) && settled(&w[1]))
        .map(|w| (w[1].kinetic_j + w[1].potential_j) - (w[0].kinetic_j + w[0].potential_j))
        .reduce(f64::max)
}

/// Why a simulation failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SimulationError {
    /// Bad settings or lengths.
    #[error(transparent)]
    Input(#[from] crate::error::InputError),
    /// The starting equilibrium could not be solved.
    #[error("starting shape: {0}")]
    Start(#[from] crate::statics::SolveError),
    /// The deadline ran out (or the run was cancelled) first.
    #[error("the run stopped: {0}")]
    Stopped(#[from] crate::budget::Stopped),
    /// A step failed.
    #[error("at t = {time:.4} s: {source}")]
    Step {
        /// When (s).
        time: f64,
        /// What failed.
        source: StepError,
    },
}

fn sample(sim: &mut Simulator<'_, Body>, body: &Body, motion: &Motion, time: f64) -> Sample {
    let (qa, qb) = body.split(&motion.q);
    let (kinetic, potential) = sim.energy(motion);
    Sample {
        time_s: time,
        lengths_m: [body.chain_a().tube_length(), body.chain_b().tube_length()],
        angles_a_rad: qa.to_vec(),
        angles_b_rad: qb.to_vec(),
        points_a_m: body.chain_a().points(qa),
        points_b_m: body.chain_b().points(qb),
        endpoint_m: body.endpoint(&motion.q),
        kinetic_j: kinetic,
        potential_j: potential,
        violation: sim.violation(&motion.q),
    }
}

/// Checks the settings and the lengths reached; returns those (m).
fn checked_target(
    robot: &crate::robot::Robot,
    lengths: [f64; 2],
    actuation: Actuation,
    options: &SimulationOptions,
) -> Result<[f64; 2], SimulationError> {
    use crate::error::positive;
    positive("duration (s)", options.duration)?;
    positive("sample interval (s)", options.sample_interval)?;
    positive("rest rate (rad/s)", options.rest_rate)?;
    crate::error::non_negative("gravity ramp (s)", options.gravity_ramp)?;
    let target = match actuation {
        Actuation::Hold => lengths,
        Actuation::Step { to } | Actuation::Feed { to, .. } => {
            robot.body(to[0], to[1])?;
            to
        }
    };
    if let Actuation::Feed { speed, .. } = actuation {
        positive("speed (m/s)", speed)?;
    }
    Ok(target)
}

/// The step (s): the one given, [`IMPLICIT_STEP_S`] for the implicit scheme, or from the
/// stability limit at `q`; at most [`MAX_STEPS`] of them in the duration.
fn step_size(body: &Body, q: &[f64], options: &SimulationOptions) -> Result<f64, SimulationError> {
    let dt = match (options.dt, options.integrator) {
        (Some(dt), _) => crate::error::positive("dt (s)", dt)?,
        (None, Integrator::Implicit) => IMPLICIT_STEP_S.min(options.duration),
        (None, integrator) => {
            let limit =
                Simulator::new(body).stable_step(q).map_err(|source| SimulationError::Step { time: 0.0, source })?;
            // The midpoint's fixed-point iteration needs dt omega < 1, RK4 dt omega < 2.8.
            if integrator == Integrator::Midpoint {
                0.3 * limit
            } else {
                limit
            }
        }
    };
    let steps_needed = options.duration / dt;
    if steps_needed > MAX_STEPS as f64 {
        return Err(crate::error::InputError::invalid(
            "duration / dt",
            steps_needed,
            format!("at most {MAX_STEPS} steps (a shorter duration or a larger dt)"),
        )
        .into());
    }
    Ok(dt)
}

/// Simulates the body of `robot` starting at tube lengths `lengths` (m).
/// `progress` receives the simulated time (s) now and then.
pub fn simulate(
    robot: &crate::robot::Robot,
    lengths: [f64; 2],
    start: Start,
    actuation: Actuation,
    options: &SimulationOptions,
    progress: &dyn Fn(f64),
) -> Result<Simulation, SimulationError> {
    use crate::statics::{Solver, SolverOptions};
    let solver = Solver::new(SolverOptions { deadline: options.deadline.clone(), ..SolverOptions::default() });
    let target = checked_target(robot, lengths, actuation, options)?;
    let mut body = robot.body(lengths[0], lengths[1])?;
    let q0 = match start {
        Start::Unloaded => {
            let mut unloaded = robot.clone();
            unloaded.world.gravity_m_per_s2 = 0.0;
            unloaded.body(lengths[0], lengths[1])?.solve(&solver)?.q
        }
        Start::Static => body.solve(&solver)?.q,
    };
    let mut motion = Motion { v: vec![0.0; q0.len()], q: q0 };
    let dt = step_size(&body, &motion.q, options)?;
    if let Actuation::Step { to } = actuation {
        let next = robot.body(to[0], to[1])?;
        motion = Motion { q: next.carry_over(&body, &motion.q), v: next.carry_over(&body, &motion.v) };
        body = next;
        Simulator::new(&body).project(&mut motion).map_err(|source| SimulationError::Step { time: 0.0, source })?;
    }
    let ramp_load = |t: f64| if options.gravity_ramp > 0.0 { (t / options.gravity_ramp).min(1.0) } else { 1.0 };
    let mut sim = Simulator::new(&body);
    sim.check(&motion).map_err(|source| SimulationError::Step { time: 0.0, source })?;
    sim.load = ramp_load(0.0);
    let mut samples = vec![sample(&mut sim, &body, &motion, 0.0)];
    let mut max_violation = samples[0].violation;
    let (mut t, mut steps, mut next_sample) = (0.0, 0usize, options.sample_interval);
    let mut current = [body.chain_a().tube_length(), body.chain_b().tube_length()];
    let mut time_to_rest = None;
    let max_steps = (options.duration / dt).ceil() as usize;
    // Simulated time in whole milliseconds, for the message of a stopped run.
    let ms = |t: f64| (t * 1e3).round() as usize;
    while steps < max_steps {
        options.deadline.guard(ms(t), ms(options.duration), "ms simulated")?;
        let fail = |time: f64| move |source| SimulationError::Step { time, source };
        if let Actuation::Feed { speed, .. } = actuation {
            let mut next = current;
            for k in 0..2 {
                let d = target[k] - current[k];
                next[k] = current[k] + d.signum() * d.abs().min(speed * dt);
            }
            if next != current {
                let fed = robot.body(next[0], next[1])?;
                motion = Motion { q: fed.carry_over(&body, &motion.q), v: fed.carry_over(&body, &motion.v) };
                body = fed;
                current = next;
                sim = Simulator::new(&body);
            }
        }
        sim.load = ramp_load(t + dt);
        let violation = sim.step(&mut motion, dt, options.integrator).map_err(fail(t))?;
        t += dt;
        steps += 1;
        max_violation = max_violation.max(violation);
        let settled_inputs = current == target && sim.load == 1.0;
        let at_rest =
            options.until_rest && settled_inputs && sim.at_rest(&motion, options.rest_rate).map_err(fail(t))?;
        if t + 1e-12 >= next_sample || at_rest || steps == max_steps {
            samples.push(sample(&mut sim, &body, &motion, t));
            next_sample += options.sample_interval;
            progress(t);
        }
        if at_rest {
            time_to_rest = Some(t);
            break;
        }
    }
    let max_energy_gain_j = energy_gain(&samples, options.gravity_ramp);
    Ok(Simulation { samples, time_to_rest, steps, dt, max_violation, max_energy_gain_j })
}
