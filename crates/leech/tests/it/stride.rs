//! The stride state machine's interlock under random command sequences.

use leech::stride::{Command, Cup, Holding, StrideError, StrideMachine};
use proptest::prelude::*;

fn cup() -> impl Strategy<Value = Cup> {
    prop_oneof![Just(Cup::Rear), Just(Cup::Front)]
}

fn command() -> impl Strategy<Value = Command> {
    // Safety factors around the minimum, and some that are not numbers.
    let factor = prop_oneof![0.0..4.0f64, Just(1.5), Just(f64::NAN), Just(f64::INFINITY)];
    prop_oneof![
        Just(Command::Move),
        (cup(), any::<bool>()).prop_map(|(cup, flush)| Command::Attach { cup, flush }),
        (cup(), factor).prop_map(|(cup, partner_safety_factor)| Command::Release { cup, partner_safety_factor }),
    ]
}

proptest! {
    /// Whatever is asked: never both cups released, never a release whose
    /// partner is released or below the minimum, never an attach that is not
    /// flush; a refusal changes nothing.
    #[test]
    fn the_interlock_holds(commands in prop::collection::vec(command(), 1..60), front in any::<bool>()) {
        let start = Holding { rear: true, front };
        let mut machine = StrideMachine::with_holding(start, 1.5).unwrap();
        for command in commands {
            let before = machine.holding();
            match machine.apply(command) {
                Ok(after) => {
                    prop_assert!(after.rear || after.front, "both released after {command:?}");
                    prop_assert_eq!(after, machine.holding());
                    match command {
                        Command::Release { cup, partner_safety_factor } => {
                            prop_assert!(before.holds(cup.other()));
                            prop_assert!(partner_safety_factor >= 1.5);
                            prop_assert!(!after.holds(cup));
                        }
                        Command::Attach { cup, flush } => {
                            prop_assert!(flush && !before.holds(cup) && after.holds(cup));
                        }
                        Command::Move => prop_assert_eq!(after, before),
                    }
                }
                Err(e) => {
                    prop_assert_eq!(machine.holding(), before, "a refusal changed the state: {}", e);
                    if let (StrideError::LastHold { cup }, Command::Release { .. }) = (&e, command) {
                        prop_assert!(!before.holds(cup.other()));
                    }
                }
            }
        }
    }
}
