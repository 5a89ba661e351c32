//! `leech serve`: the console's robot, place, link and listening address.

use std::net::SocketAddr;
use std::path::Path;

use leech_console::server::check_listen;
use leech_console::{Setup, Source};

use super::link::place;
use super::tuned;
use crate::failure::Failure;
use crate::flags::ServeArgs;

/// The scenario a console shows when given neither a scenario nor a scene:
/// the robot starts held on a floor, with a goal ahead.
pub const DEFAULT_SCENARIO: &str = "crawl-floor";

/// Where `leech serve` listens unless told.
pub const DEFAULT_LISTEN: &str = "127.0.0.1:8080";

/// `leech serve`: what to drive and where to listen.
pub struct Serve {
    pub setup: Setup,
    /// Where to listen; `None`: the default, or a free port if it is taken.
    pub listen: Option<SocketAddr>,
    pub token: Option<String>,
}

pub(super) fn serve(a: ServeArgs) -> Result<Serve, Failure> {
    let robot = tuned(&a.robot, Ok)?;
    let default = (a.scenario.is_none() && a.scene.is_none()).then(|| Path::new(DEFAULT_SCENARIO));
    let scenario = a.scenario.as_deref().or(default);
    let place = place(&robot, scenario, a.scene.as_deref())?
        .ok_or_else(|| Failure::Input("serve: give --scenario or --scene".into()))?;
    let listen_at = a.listen.unwrap_or_else(|| DEFAULT_LISTEN.parse().expect("the default address parses"));
    check_listen(listen_at, a.token.as_deref()).map_err(|e| Failure::Input(e.to_string()))?;
    let source = match a.port {
        Some(port) => Source::Port(port),
        None => Source::Simulated,
    };
    let setup = Setup { robot, scene: place.scene, start: place.start, goal: place.goal, source };
    Ok(Serve { setup, listen: a.listen, token: a.token })
}
