//! Cooperative cancellation: how long a computation may run, and how it says
//! it stopped.
//!
//! A [`Deadline`] is a wall-clock instant (fixed when it is made, so one
//! deadline bounds a whole command, every solve inside it together) plus an
//! optional shared cancel flag another thread may raise. Long computations
//! check it at their natural step (a Newton iteration, a continuation step, a
//! grid point, a descent, a time step, a fit's residual) and stop with a
//! typed error saying what was done ([`Stopped`]). Checking costs one clock
//! read and one relaxed atomic load (tens of nanoseconds), negligible beside
//! any step it guards. Cloning shares the flag; a clone sent to rayon's
//! workers stops them all.

use std::fmt;
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::Arc;
use std::time::{Duration, Instant};

/// When a computation must stop: a wall-clock deadline and an optional shared
/// cancel flag. [`Deadline::none`] (the default) never expires.
#[derive(Clone, Debug, Default)]
pub struct Deadline {
    /// The instant and the limit it was made from (for messages).
    at: Option<(Instant, Duration)>,
    cancel: Option<Arc<AtomicBool>>,
}

/// Why a computation stopped early.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub enum Halt {
    /// The wall-clock limit ran out.
    TimeLimit(Duration),
    /// The cancel flag was raised.
    Cancelled,
}

impl fmt::Display for Halt {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Halt::TimeLimit(limit) => write!(f, "time limit of {} s reached", limit.as_secs_f64()),
            Halt::Cancelled => f.write_str("cancelled"),
        }
    }
}

impl Deadline {
    /// No deadline and no cancel flag: never expires.
    pub fn none() -> Deadline {
        Deadline::default()
    }

    /// Expires `limit` from now.
    pub fn after(limit: Duration) -> Deadline {
        // A limit beyond what the clock can represent is no limit at all.
        Deadline { at: Instant::now().checked_add(limit).map(|at| (at, limit)), cancel: None }
    }

    /// The same deadline, also expiring when `flag` is raised.
    pub fn with_cancel(mut self, flag: Arc<AtomicBool>) -> Deadline {
        self.cancel = Some(flag);
        self
    }

    /// The limit it was made with, if any.
    pub fn limit(&self) -> Option<Duration> {
        self.at.map(|(_, limit)| limit)
    }

    /// Why it has expired, or `None` while the computation may go on.
    pub fn check(&self) -> Option<Halt> {
        if self.cancel.as_ref().is_some_and(|flag| flag.load(Ordering::Relaxed)) {
            return Some(Halt::Cancelled);
        }
        match self.at {
            Some((at, limit)) if Instant::now() >= at => Some(Halt::TimeLimit(limit)),
            _ => None,
        }
    }

    /// Whether it has expired.
    pub fn expired(&self) -> bool {
        self.check().is_some()
    }

    /// `Err(Stopped)` with `done` of `total` `unit` when expired.
    pub fn guard(&self, done: usize, total: usize, unit: &'static str) -> Result<(), Stopped> {
        match self.check() {
            Some(halt) => Err(Stopped { halt, done, total, unit }),
            None => Ok(()),
        }
    }
}

/// Two deadlines are equal when they expire together on the same flag.
impl PartialEq for Deadline {
    fn eq(&self, other: &Deadline) -> bool {
        let same_flag = match (&self.cancel, &other.cancel) {
            (Some(a), Some(b)) => Arc::ptr_eq(a, b),
            (None, None) => true,
            _ => false,
        };
        self.at == other.at && same_flag
    }
}

/// A computation stopped by its [`Deadline`], and how far it came.
#[derive(Clone, Debug, PartialEq, Eq, thiserror::Error)]
#[error("{halt} after {done} of {total} {unit}")]
pub struct Stopped {
    /// Why it stopped.
    pub halt: Halt,
    /// Units of work finished.
    pub done: usize,
    /// Units of work in the whole job.
    pub total: usize,
    /// What a unit is ("points", "map points", "ms simulated", ...).
    pub unit: &'static str,
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn none_never_expires_and_zero_expires_at_once() {
        assert!(!Deadline::none().expired());
        assert_eq!(Deadline::after(Duration::ZERO).check(), Some(Halt::TimeLimit(Duration::ZERO)));
        assert!(!Deadline::after(Duration::from_secs(3600)).expired());
        assert!(!Deadline::after(Duration::MAX).expired(), "an unrepresentable instant is no limit");
    }

    #[test]
    fn a_raised_flag_stops_every_clone() {
        let flag = Arc::new(AtomicBool::new(false));
        let deadline = Deadline::after(Duration::from_secs(3600)).with_cancel(flag.clone());
        let worker = deadline.clone();
        assert!(worker.guard(1, 2, "points").is_ok());
        flag.store(true, Ordering::Relaxed);
        let stopped = worker.guard(1, 2, "points").unwrap_err();
        assert_eq!(stopped.to_string(), "cancelled after 1 of 2 points");
        assert_eq!(deadline, worker);
    }

    #[test]
    fn the_message_says_what_was_done() {
        let stopped = Deadline::after(Duration::from_secs(2)).guard(812, 4000, "points");
        assert!(stopped.is_ok());
        let stopped = Stopped { halt: Halt::TimeLimit(Duration::from_secs(2)), done: 812, total: 4000, unit: "points" };
        assert_eq!(stopped.to_string(), "time limit of 2 s reached after 812 of 4000 points");
    }
}
