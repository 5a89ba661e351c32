//! The stride's state machine: which cups hold, and the interlock that
//! guards every change.
//!
//! Rules (paper Fig. 6; a release that breaks them is a fall):
//!
//! 1. At least one cup holds in every state: a cup may be released only
//!    while the other holds.
//! 2. A cup may be released only when the other cup's safety factor *after*
//!    the release (capacity / load, from the statics of the state the
//!    release leads to, or from sensors) is at least the minimum (the robot
//!    file's `[cup] min_safety_factor`, 1.5 by default). A factor that is not
//!    a number counts as too low.
//! 3. A cup may attach only where its face lies flush on a surface (within
//!    the robot file's distance and angle tolerances).
//! 4. Tubes may move in any state (one cup always holds).
//!
//! The machine holds no physics: the caller brings the evidence (the safety
//! factor, whether the face is flush) with each command. A refused command
//! leaves the state as it was and says which rule it breaks.

use serde::Serialize;

use crate::error::InputError;

/// One of the two suction cups.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "lowercase")]
pub enum Cup {
    /// The cup on the driving unit.
    Rear,
    /// The cup on the endpoint plate.
    Front,
}

impl Cup {
    /// The other cup.
    pub fn other(self) -> Cup {
        match self {
            Cup::Rear => Cup::Front,
            Cup::Front => Cup::Rear,
        }
    }

    /// Its name, as the JSON writes it.
    pub fn name(self) -> &'static str {
        match self {
            Cup::Rear => "rear",
            Cup::Front => "front",
        }
    }
}

impl std::fmt::Display for Cup {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str(self.name())
    }
}

/// Which cups hold.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
pub struct Holding {
    /// The rear cup holds.
    pub rear: bool,
    /// The front cup holds.
    pub front: bool,
}

impl Holding {
    /// Whether `cup` holds.
    pub fn holds(&self, cup: Cup) -> bool {
        match cup {
            Cup::Rear => self.rear,
            Cup::Front => self.front,
        }
    }

    /// The same with `cup` holding or not.
    pub fn with(mut self, cup: Cup, holds: bool) -> Holding {
        match cup {
            Cup::Rear => self.rear = holds,
            Cup::Front => self.front = holds,
        }
        self
    }

    /// "rear", "front" or "both" (as `leech shape --hold` takes it); `None`
    /// when neither holds, which no state of the machine is.
    pub fn name(&self) -> Option<&'static str> {
        match (self.rear, self.front) {
            (true, true) => Some("both"),
            (true, false) => Some("rear"),
            (false, true) => Some("front"),
            (false, false) => None,
        }
    }
}

/// The phases of one stride, in order (paper Fig. 6).
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// Where a climb starts: the rear cup holds, the tubes at their shortest.
    Start,
    /// The rear cup holds; the tubes are fed to the stride's lengths.
    Push,
    /// The front cup attaches where its face lies flush.
    AttachFront,
    /// The rear cup releases; the body settles on the front cup.
    ReleaseRear,
    /// The front cup holds; the tubes are drawn in and the driving unit travels.
    Pull,
    /// The rear cup attaches.
    AttachRear,
    /// The front cup releases; the body settles on the rear cup.
    ReleaseFront,
}

impl Phase {
    /// Its name, as the JSON and CSV write it.
    pub fn name(self) -> &'static str {
        match self {
            Phase::Start => "start",
            Phase::Push => "push",
            Phase::AttachFront => "attach_front",
            Phase::ReleaseRear => "release_rear",
            Phase::Pull => "pull",
            Phase::AttachRear => "attach_rear",
            Phase::ReleaseFront => "release_front",
        }
    }

    /// The phase of a name as [`Phase::name`] writes it.
    pub fn from_name(name: &str) -> Option<Phase> {
        [
            Phase::Start,
            Phase::Push,
            Phase::AttachFront,
            Phase::ReleaseRear,
            Phase::Pull,
            Phase::AttachRear,
            Phase::ReleaseFront,
        ]
        .into_iter()
        .find(|p| p.name() == name)
    }

    /// The command of this phase, with its evidence.
    pub fn command(self, evidence: Evidence) -> Command {
        match self {
            Phase::Start | Phase::Push | Phase::Pull => Command::Move,
            Phase::AttachFront => Command::Attach { cup: Cup::Front, flush: evidence.flush },
            Phase::AttachRear => Command::Attach { cup: Cup::Rear, flush: evidence.flush },
            Phase::ReleaseRear => Command::Release { cup: Cup::Rear, partner_safety_factor: evidence.safety_factor },
            Phase::ReleaseFront => Command::Release { cup: Cup::Front, partner_safety_factor: evidence.safety_factor },
        }
    }
}

/// What a phase's command is judged on.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct Evidence {
    /// For an attach: whether the face lies flush.
    pub flush: bool,
    /// For a release: the other cup's safety factor after it.
    pub safety_factor: f64,
}

/// A change the machine is asked for, with its evidence.
#[derive(Clone, Copy, Debug, PartialEq)]
pub enum Command {
    /// Tubes pushed, pulled or jogged.
    Move,
    /// A cup attaches; `flush`: its face lies flush on a surface.
    Attach {
        /// Which cup.
        cup: Cup,
        /// Whether its face lies flush within the tolerances.
        flush: bool,
    },
    /// A cup releases; the other cup's safety factor once it has.
    Release {
        /// Which cup.
        cup: Cup,
        /// The other cup's safety factor after the release.
        partner_safety_factor: f64,
    },
}

/// Why the machine refused a command.
#[derive(Clone, Debug, PartialEq, thiserror::Error)]
pub enum StrideError {
    /// Attaching a cup that already holds.
    #[error("attach {cup}: the {cup} cup already holds")]
    AlreadyHolding {
        /// The cup.
        cup: Cup,
    },
    /// Releasing a cup that does not hold.
    #[error("release {cup}: the {cup} cup is already released")]
    AlreadyReleased {
        /// The cup.
        cup: Cup,
    },
    /// Releasing the only cup that holds.
    #[error("release {cup}: refused, the {other} cup is released and the robot would fall (one cup must always hold)", other = cup.other())]
    LastHold {
        /// The cup asked to release.
        cup: Cup,
    },
    /// Releasing a cup whose partner would then hold below the minimum safety factor.
    #[error("release {cup}: refused, the {other} cup would hold with safety factor {factor:.3}, below the minimum {minimum}", other = cup.other())]
    BelowSafetyFactor {
        /// The cup asked to release.
        cup: Cup,
        /// The partner's safety factor after the release (NaN if unknown).
        factor: f64,
        /// The minimum.
        minimum: f64,
    },
    /// Attaching a cup whose face does not lie flush on a surface.
    #[error("attach {cup}: refused, the {cup} cup's face is not flush on a surface within the tolerances")]
    NotFlush {
        /// The cup.
        cup: Cup,
    },
}

/// The stride's state (which cups hold) behind its interlock (module doc).
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct StrideMachine {
    holding: Holding,
    min_safety_factor: f64,
}

impl StrideMachine {
    /// A machine with the rear cup holding and the front released (where a
    /// stride starts), refusing releases below `min_safety_factor` (at least 1).
    pub fn new(min_safety_factor: f64) -> Result<StrideMachine, InputError> {
        StrideMachine::with_holding(Holding { rear: true, front: false }, min_safety_factor)
    }

    /// A machine in a given state (a robot found holding so).
    pub fn with_holding(holding: Holding, min_safety_factor: f64) -> Result<StrideMachine, InputError> {
        if !(min_safety_factor >= 1.0 && min_safety_factor.is_finite()) {
            return Err(InputError::Invalid {
                field: "min_safety_factor".into(),
                value: format!("{min_safety_factor}"),
                allowed: "a number of at least 1".into(),
            });
        }
        if holding.name().is_none() {
            return Err(InputError::Invalid {
                field: "holding".into(),
                value: "neither cup".into(),
                allowed: "at least one cup holding".into(),
            });
        }
        Ok(StrideMachine { holding, min_safety_factor })
    }

    /// Which cups hold.
    pub fn holding(&self) -> Holding {
        self.holding
    }

    /// The smallest safety factor a release may leave.
    pub fn min_safety_factor(&self) -> f64 {
        self.min_safety_factor
    }

    /// What `command` would lead to, or why it is refused, without doing it
    /// (an operator's console greys a button out with the reason).
    pub fn check(&self, command: Command) -> Result<Holding, StrideError> {
        let holding = self.holding;
        match command {
            Command::Move => Ok(holding),
            Command::Attach { cup, flush } => {
                if holding.holds(cup) {
                    Err(StrideError::AlreadyHolding { cup })
                } else if !flush {
                    Err(StrideError::NotFlush { cup })
                } else {
                    Ok(holding.with(cup, true))
                }
            }
            Command::Release { cup, partner_safety_factor: factor } => {
                if !holding.holds(cup) {
                    Err(StrideError::AlreadyReleased { cup })
                } else if !holding.holds(cup.other()) {
                    Err(StrideError::LastHold { cup })
                } else if !(factor >= self.min_safety_factor) {
                    Err(StrideError::BelowSafetyFactor { cup, factor, minimum: self.min_safety_factor })
                } else {
                    Ok(holding.with(cup, false))
                }
            }
        }
    }

    /// Carries `command` out if the interlock allows it; a refusal leaves
    /// the state unchanged.
    pub fn apply(&mut self, command: Command) -> Result<Holding, StrideError> {
        self.holding = self.check(command)?;
        Ok(self.holding)
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_whole_stride_passes_and_each_rule_refuses() {
        let mut m = StrideMachine::new(1.5).unwrap();
        let release_rear = |sf| Command::Release { cup: Cup::Rear, partner_safety_factor: sf };
        assert_eq!(m.apply(release_rear(9.0)), Err(StrideError::LastHold { cup: Cup::Rear }));
        assert_eq!(
            m.apply(Command::Attach { cup: Cup::Front, flush: false }),
            Err(StrideError::NotFlush { cup: Cup::Front })
        );
        assert_eq!(m.apply(Command::Attach { cup: Cup::Front, flush: true }).unwrap().name(), Some("both"));
        let low = m.apply(release_rear(1.2)).unwrap_err();
        assert_eq!(
            low.to_string(),
            "release rear: refused, the front cup would hold with safety factor 1.200, below the minimum 1.5"
        );
        assert!(matches!(m.apply(release_rear(f64::NAN)), Err(StrideError::BelowSafetyFactor { .. })));
        assert_eq!(m.holding().name(), Some("both"));
        assert_eq!(m.apply(release_rear(1.5)).unwrap().name(), Some("front"));
        assert_eq!(m.apply(release_rear(3.0)), Err(StrideError::AlreadyReleased { cup: Cup::Rear }));
        assert_eq!(
            m.apply(Command::Attach { cup: Cup::Front, flush: true }),
            Err(StrideError::AlreadyHolding { cup: Cup::Front })
        );
        assert!(StrideMachine::new(0.9).is_err());
        assert!(StrideMachine::with_holding(Holding { rear: false, front: false }, 1.5).is_err());
    }
}
