//! What a solve returns: equilibria, events on the way, and failures.

use crate::budget::Halt;
use std::fmt;

/// Which part of a solve something happened in.
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Stage {
    /// The tubes fed from equal lengths at `g = 0`.
    Feed,
    /// Gravity raised from 0 to `g`.
    Load,
    /// A minimization from a given state (no continuation).
    #[serde(rename = "warm start")]
    WarmStart,
}

impl Stage {
    /// The name printed and serialized.
    pub fn name(self) -> &'static str {
        match self {
            Stage::Feed => "feed",
            Stage::Load => "load",
            Stage::WarmStart => "warm start",
        }
    }
}

impl fmt::Display for Stage {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl PartialEq<&str> for Stage {
    fn eq(&self, other: &&str) -> bool {
        self.name() == *other
    }
}

/// The side a symmetric bifurcation was left to, relative to the clamp
/// direction ([`StaticSystem::side_measure`](super::StaticSystem::side_measure)).
#[derive(Clone, Copy, Debug, PartialEq, Eq, serde::Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Side {
    /// Where the side measure is positive (for the robot: towards chain B).
    Right,
    /// The other side.
    Left,
}

impl Side {
    /// The name printed and serialized.
    pub fn name(self) -> &'static str {
        match self {
            Side::Right => "right",
            Side::Left => "left",
        }
    }
}

impl fmt::Display for Side {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

impl PartialEq<&str> for Side {
    fn eq(&self, other: &&str) -> bool {
        self.name() == *other
    }
}

/// Something that happened on the way to an equilibrium.
#[derive(Clone, Debug, PartialEq, serde::Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum Event {
    /// The path met a fold and the body snapped through to another branch.
    Snap {
        /// Which path.
        stage: Stage,
        /// Path parameter at the fold (0..1; the fraction of g on the load path).
        #[serde(rename = "at_path_fraction")]
        at: f64,
        /// Largest angle change across the snap (rad).
        jump_rad: f64,
    },
    /// The path crossed a symmetric bifurcation and left the unstable branch.
    Bifurcation {
        /// Which path.
        stage: Stage,
        /// Path parameter where the branch was found unstable.
        #[serde(rename = "at_path_fraction")]
        at: f64,
        /// The side chosen.
        side: Side,
        /// Largest angle change from the last stable state (rad): small for a
        /// supercritical pitchfork, large when the body falls far.
        jump_rad: f64,
    },
}

/// Why a Newton run stopped without converging (serialized as its phrase).
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum StopReason {
    /// The residual became NaN or infinite.
    NonFinite,
    /// The iteration budget ran out.
    IterationLimit,
    /// The wall-clock limit ran out.
    TimeLimit,
    /// No inertia-correcting shift made the step well defined.
    SingularJacobian,
    /// Every trial step was rejected.
    NoDescent,
    /// The corrector wandered off the predicted branch.
    LeftBranch,
    /// The minimization from an unstable equilibrium ended on another unstable one.
    StillUnstable,
    /// The branch rule forbids leaving an unstable equilibrium.
    UnstableRefused,
    /// The continuation used up its steps.
    StepLimit,
    /// Inequality rows kept switching between active and inactive.
    ActiveSetCycling,
    /// A stage would move the tubes through a solid between two solved
    /// shapes, however short (the swept-motion test of [`crate::stance`]).
    SweptThroughSolid,
    /// More rows would act at once than the factorization holds
    /// ([`crate::linalg::MAX_BORDER`] less the free coordinates).
    TooManyActiveRows,
}

impl StopReason {
    /// The phrase printed in messages.
    pub fn describe(self) -> &'static str {
        match self {
            StopReason::NonFinite => "non-finite residual",
            StopReason::IterationLimit => "iteration limit reached",
            StopReason::TimeLimit => "time limit reached",
            StopReason::SingularJacobian => "singular constraint Jacobian",
            StopReason::NoDescent => "no descent step found",
            StopReason::LeftBranch => "left the branch",
            StopReason::StillUnstable => "could not leave an unstable equilibrium",
            StopReason::UnstableRefused => "unstable equilibrium (the branch rule refuses to leave it)",
            StopReason::StepLimit => "continuation step limit reached",
            StopReason::ActiveSetCycling => "contacts kept switching on and off",
            StopReason::SweptThroughSolid => "the tubes would pass through a solid between two shapes",
            StopReason::TooManyActiveRows => {
                "more constraint rows act at once than the solver holds (64 less the free coordinates)"
            }
        }
    }
}

impl serde::Serialize for StopReason {
    fn serialize<S: serde::Serializer>(&self, serializer: S) -> Result<S::Ok, S::Error> {
        serializer.serialize_str(self.describe())
    }
}

impl fmt::Display for StopReason {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.describe())
    }
}

/// Why a solve failed.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum SolveError {
    /// Newton's method did not reach the tolerance within its bounds.
    #[error("{stage}: not converged after {iterations} iterations (residual {residual:.3e}): {reason}")]
    NotConverged {
        /// Stage of the solve that failed.
        stage: Stage,
        /// Iterations spent in the whole solve.
        iterations: usize,
        /// Scaled residual when it stopped.
        residual: f64,
        /// What stopped it.
        reason: StopReason,
    },
    /// The deadline ran out or the job was cancelled.
    #[error("{halt} after {iterations} iterations (residual {residual:.3e})")]
    Stopped {
        /// Why it stopped.
        halt: Halt,
        /// Iterations spent.
        iterations: usize,
        /// Scaled residual when it stopped.
        residual: f64,
    },
    /// A starting state of the wrong size or with non-finite entries.
    #[error("starting state has {got} finite angles, expected {expected}")]
    BadStart {
        /// Expected number of coordinates.
        expected: usize,
        /// Number of finite coordinates given.
        got: usize,
    },
}

/// A converged equilibrium and how it was reached.
#[derive(Clone, Debug, PartialEq)]
pub struct Equilibrium {
    /// Generalized coordinates (absolute link angles, rad).
    pub q: Vec<f64>,
    /// Lagrange multipliers of the constraints (N and N m); zero for an
    /// inactive inequality row.
    pub multipliers: Vec<f64>,
    /// Potential energy (J).
    pub energy: f64,
    /// Scaled residual sup norm at the solution.
    pub residual: f64,
    /// Whether the reduced Hessian is positive definite (a stable equilibrium).
    pub stable: bool,
    /// Newton iterations spent, all stages together.
    pub iterations: usize,
    /// Continuation steps accepted, all paths together.
    pub steps: usize,
    /// Folds and bifurcations met on the way.
    pub events: Vec<Event>,
}
