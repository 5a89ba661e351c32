//! Strides and climbs: the stride's state machine with its interlock
//! ([`machine`]) and the climb planner ([`plan`]).

pub mod machine;
pub mod plan;

pub use machine::{Command, Cup, Evidence, Holding, Phase, StrideError, StrideMachine};
pub use plan::{plan, Blocking, Foothold, Goal, Plan, PlanOptions, Rejection, Status, Step};
