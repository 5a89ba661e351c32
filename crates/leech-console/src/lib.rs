//! # leech-console: the operator's web console
//!
//! A web server (`leech serve`) with one page that shows the robot and its
//! surroundings to scale, as the model predicts the body from the measured
//! tube lengths, and drives the real or the simulated robot through the
//! same link ([`leech_link::host::Link`]).
//!
//! Rules:
//!
//! * **The server judges every command** ([`console::Console::handle`]);
//!   the page only asks. Lengths must lie within the robot file's
//!   `[limits]`, a jog within [`console::MAX_JOG_MM`] and the limits; a pump
//!   switched off while its cup holds, and every stride phase, pass the
//!   stride's interlock ([`leech::stride::StrideMachine`]) on the model's
//!   evidence (a free cup's face flush; the other cup's safety factor after
//!   a release at least the robot's minimum); plans and single phases run
//!   through [`leech_link::executor::Executor`], which judges them again,
//!   and the console's interlock judges each cup step of a run again on
//!   the live model just before it. A pump switched on is an attach when
//!   its cup is free and the other holds (refused unless the face lies
//!   flush: a pull would otherwise make it grip unjudged); on a cup that
//!   already holds it changes nothing and is allowed; while no cup holds
//!   (the robot lies free) it is allowed, since a grip can only add a
//!   hold. Lengths, jogs and pumps are refused while a run goes on, and
//!   any of them, or a stride by hand, drops the previewed plan: a plan is
//!   carried out only from the state it was planned in.
//!   Every refusal names the field, the value and what is allowed, and
//!   changes nothing. Malformed, unknown, oversized and non-finite
//!   messages are refused the same way ([`messages::parse`]).
//! * **Stop** halts the motors at once and cancels a plan's remaining
//!   steps; the step in progress ends when its wait for the lengths fails
//!   (the executor's bound). The pumps stay as they are.
//! * **One driver.** The first tab to take control drives; the others
//!   watch. Control is released by the tab, when it disconnects, or when
//!   nothing came from it for [`server::LEASE`] (10 s; the page pings every
//!   2 s while it drives, so a hung or vanished tab cannot lock the others
//!   out); a tab that stops reading is dropped. Any tab
//!   may stop the robot, and ask for a reach preview or the workspace
//!   (nothing moves).
//! * **Everyone sees the same state**, sent to every tab every
//!   [`server::STATE_PERIOD`] (50 Hz): telemetry, commanded lengths, link
//!   health, the predicted body and its cups, which stride phases the
//!   interlock allows now and why not, and the run's progress.
//! * **Local by default.** The server binds to a loopback address unless
//!   told otherwise, and any other address needs a token
//!   ([`server::check_listen`]); a websocket from a page of another origin
//!   is refused. The page, its script and style are embedded in the binary:
//!   nothing is fetched from the network at run time.
//! * **Bytes from the network never panic the server**: every message is
//!   parsed into typed requests first, and long computations (reach, plan,
//!   workspace) run one at a time on threads of their own.

#![warn(missing_docs)]

pub mod console;
pub mod messages;
pub mod model;
pub mod server;

pub use console::{Console, Setup, Source};
