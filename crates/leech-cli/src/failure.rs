//! Why a command stopped, sorted by exit code; the library's errors map here
//! once, so every command reports them alike.

use leech::budget::Stopped;
use leech::calibration::CalibrationError;
use leech::dynamics::SimulationError;
use leech::error::JobError;
use leech::prelude::*;
use leech::stance::StanceError;
use leech_plot::figures::FigureError;
use leech_plot::PlotError;

/// Why the command stopped.
pub enum Failure {
    /// Bad input (exit 2): one line naming the field, the value and what is allowed.
    Input(String),
    /// A solve that did not converge (exit 3; its status is printed with
    /// --json), and what to say of it.
    Solve(SolveError, String),
    /// Another computation that did not converge (exit 3): a fit, a simulation step.
    Unsolved(String),
    /// Anything else (exit 1).
    Other(anyhow::Error),
}

impl From<InputError> for Failure {
    fn from(e: InputError) -> Self {
        Failure::Input(e.to_string())
    }
}

impl From<SolveError> for Failure {
    fn from(e: SolveError) -> Self {
        let hint = if matches!(e, SolveError::Stopped { .. }) { RAISE } else { "" };
        let message = format!("solve failed: {e}{hint}");
        Failure::Solve(e, message)
    }
}

/// How to get further when a job ran out of time.
const RAISE: &str = "; raise --time-limit to go further";

/// A job stopped by its deadline (exit 3): what was done, how to go further.
impl From<Stopped> for Failure {
    fn from(e: Stopped) -> Self {
        Failure::Unsolved(format!("stopped: {e}{RAISE}"))
    }
}

/// A grid job (`workspace`, `reach`) that had bad input or ran out of time:
/// `job` names it, `unwritten` says what it did not write.
pub fn grid_job(e: JobError, job: &str, unwritten: &str) -> Failure {
    match e {
        JobError::Input(e) => e.into(),
        JobError::Stopped(e) => {
            Failure::Unsolved(format!("{job} stopped: {e}{unwritten}{RAISE} or use a coarser --lengths-range"))
        }
    }
}

impl From<StanceError> for Failure {
    fn from(e: StanceError) -> Self {
        match e {
            StanceError::Input(e) => e.into(),
            StanceError::Solve(e) => e.into(),
            StanceError::OutOfReach { ref source, .. } => Failure::Solve(source.clone(), e.to_string()),
        }
    }
}

impl From<anyhow::Error> for Failure {
    fn from(e: anyhow::Error) -> Self {
        Failure::Other(e)
    }
}

impl From<PlotError> for Failure {
    fn from(e: PlotError) -> Self {
        Failure::Other(e.into())
    }
}

impl From<FigureError> for Failure {
    fn from(e: FigureError) -> Self {
        match e {
            FigureError::Input(e) => e.into(),
            FigureError::Solve { source, .. } => source.into(),
            FigureError::Plot(e) => e.into(),
        }
    }
}

impl From<CalibrationError> for Failure {
    fn from(e: CalibrationError) -> Self {
        match e {
            CalibrationError::Model(message) => Failure::Unsolved(format!("fit failed: {message}")),
            CalibrationError::Stopped(e) => e.into(),
            other => Failure::Input(other.to_string()),
        }
    }
}

impl From<SimulationError> for Failure {
    fn from(e: SimulationError) -> Self {
        match e {
            SimulationError::Input(e) => e.into(),
            SimulationError::Start(e) => e.into(),
            SimulationError::Stopped(e) => {
                Failure::Unsolved(format!("simulation stopped: {e}, nothing written{RAISE}"))
            }
            other => Failure::Unsolved(format!("simulation failed: {other}")),
        }
    }
}
