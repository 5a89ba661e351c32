//! Strides and climbs: the stride's state machine with its interlock
//! ([`machine`]).

pub mod machine;

pub use machine::{Command, Cup, Evidence, Holding, Phase, StrideError, StrideMachine};
