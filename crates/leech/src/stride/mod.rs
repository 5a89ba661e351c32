//! Strides and climbs: the stride's state machine with its interlock
//! ([`machine`]), the climb planner ([`mod@plan`]) and the climbs to plan
//! ([`scenario`]).

pub mod machine;
pub mod plan;
pub mod scenario;
pub mod sideways;

pub use machine::{Command, Cup, Evidence, Holding, Phase, StrideError, StrideMachine};
pub use plan::{
    plan, plan_with_progress, Blocking, Failed, Foothold, Goal, Plan, PlanOptions, Progress, Rejection, Status, Step,
};
pub use scenario::{BuiltinScenario, Scenario, BUILTIN_SCENARIOS};
pub use sideways::{plan_sideways, SidewaysOptions, SidewaysPlan, SidewaysScenario, SidewaysStep, Wall};
