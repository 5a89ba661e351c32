//! The web server: one page (embedded), one websocket, a token when asked.
//!
//! * `GET /` serves the page; `GET /ws` upgrades to the websocket. With a
//!   token, both require `?token=T` (the page passes it on to its socket).
//! * A request whose `Host` is not this server's address is refused (403),
//!   the page and the websocket alike: a site whose name an attacker points
//!   at 127.0.0.1 (DNS rebinding) would otherwise be "same origin". On a
//!   loopback address the names are `localhost`, `127.0.0.1`, `[::1]` and
//!   the address itself, with the port; on another address, that address
//!   with the port; on every interface (`0.0.0.0`, `::`), any name, since
//!   the token (required there) is what keeps other sites out.
//! * A websocket whose `Origin` is not this server's own is refused: a web
//!   page from elsewhere open in the operator's browser must not reach a
//!   robot on 127.0.0.1.
//! * Every tab is sent the hello ([`Console::hello`]) and then the state
//!   every [`STATE_PERIOD`], and as soon as the model has a new body (at
//!   most every [`MIN_STATE_GAP`]); a slow tab skips states rather than queueing
//!   them. A tab that does not read what it is sent within
//!   [`SEND_DEADLINE`], or from which nothing comes (not even a pong) for
//!   [`SILENCE`], is dropped, and with it its control.
//! * **Control is a lease**: the driving tab loses control when nothing
//!   (request or `ping`) came from it for [`LEASE`]; then any tab may take
//!   control. The page pings every 2 s while it drives, so only a hung,
//!   frozen or vanished tab lapses.
//! * **A stop never waits**: it is carried out as soon as it is read, ahead
//!   of the tab's requests still waiting (at most [`QUEUE`]), and the moves
//!   queued before it, by any tab, are refused.
//! * Requests are judged by [`Console::handle`], in the order a tab
//!   sent them; a refusal comes back as `{"type": "error", ...}`.

use std::collections::HashMap;
use std::net::SocketAddr;
use std::sync::atomic::{AtomicU64, Ordering};
use std::sync::Arc;
use std::sync::{Mutex, MutexGuard};
use std::time::{Duration, Instant};

use axum::extract::ws::{Message, WebSocket, WebSocketUpgrade};
use axum::extract::{Query, State};
use axum::http::{header, HeaderMap, StatusCode};
use axum::response::{Html, IntoResponse, Response};
use axum::routing::get;
use axum::Router;
use serde_json::json;
use tokio::net::TcpListener;
use tokio::sync::{mpsc, watch};

use crate::console::Console;
use crate::messages::{self, Refusal, Request, MAX_REQUEST_BYTES};

/// How often the state is sent to every tab: 50 Hz.
pub const STATE_PERIOD: Duration = Duration::from_millis(20);

/// The shortest time between two states: at most 100 a second.
pub const MIN_STATE_GAP: Duration = Duration::from_millis(10);

/// How long the driving tab keeps control without sending anything: then
/// any tab may take it. The page sends a ping every 2 s while it drives.
pub const LEASE: Duration = Duration::from_secs(10);

/// How long a message to a tab may wait to be sent: a tab that does not
/// read is dropped then (and with it its control).
pub const SEND_DEADLINE: Duration = Duration::from_secs(5);

/// How many requests of a tab may wait for the ones before them; more are
/// refused.
pub const QUEUE: usize = 256;

/// How often the server pings every tab.
pub const PING_PERIOD: Duration = Duration::from_secs(5);

/// A tab from which nothing came for this long (not even the pong of a
/// ping) is dropped.
pub const SILENCE: Duration = Duration::from_secs(20);

const INDEX: &str = include_str!("../assets/index.html");
const SCRIPT: &str = include_str!("../assets/console.js");
const STYLE: &str = include_str!("../assets/console.css");

/// Why the server may not listen where asked.
#[derive(Debug, thiserror::Error, PartialEq)]
pub enum ListenError {
    /// Another machine could reach the robot: a token is needed.
    #[error("--listen {0}: not a loopback address, and the page moves a robot: give --token T (8 or more letters, digits, '-', '_' or '.')")]
    NeedsToken(SocketAddr),
    /// The token is too short or has characters a URL would mangle.
    #[error("--token: expected 8 or more letters, digits, '-', '_' or '.', got {0} characters")]
    BadToken(usize),
}

/// Checks the listening address and the token: any address other than a
/// loopback one needs a token.
pub fn check_listen(addr: SocketAddr, token: Option<&str>) -> Result<(), ListenError> {
    if let Some(t) = token {
        let fine = t.len() >= 8 && t.chars().all(|c| c.is_ascii_alphanumeric() || "-_.".contains(c));
        if !fine {
            return Err(ListenError::BadToken(t.chars().count()));
        }
    } else if !addr.ip().is_loopback() {
        return Err(ListenError::NeedsToken(addr));
    }
    Ok(())
}

#[derive(Clone)]
struct App {
    console: Arc<Console>,
    token: Option<Arc<str>>,
    state: watch::Receiver<Arc<str>>,
    hosts: Hosts,
    /// When each open tab last sent a message (a request or a ping).
    heard: Arc<Mutex<HashMap<u64, Instant>>>,
    /// How many stops were asked (by any tab).
    stops: Arc<AtomicU64>,
}

/// The `Host` values this server answers to.
#[derive(Clone, Debug)]
enum Hosts {
    /// Any (listening on every interface: the token guards it).
    Any,
    /// These, compared without regard to case.
    Only(Arc<[String]>),
}

impl Hosts {
    fn of(addr: SocketAddr) -> Hosts {
        let ip = addr.ip();
        if ip.is_unspecified() {
            return Hosts::Any;
        }
        let port = addr.port();
        let mut names = vec![addr.to_string()];
        if ip.is_loopback() {
            for name in ["localhost", "127.0.0.1", "[::1]"] {
                names.push(format!("{name}:{port}"));
            }
        }
        if port == 80 {
            // A browser leaves out the default port.
            let bare: Vec<String> = names.iter().filter_map(|n| n.strip_suffix(":80").map(str::to_string)).collect();
            names.extend(bare);
        }
        Hosts::Only(names.into())
    }

    /// Whether a request's `Host` header names this server.
    fn admit(&self, headers: &HeaderMap) -> bool {
        match self {
            Hosts::Any => true,
            Hosts::Only(names) => {
                let host = headers.get(header::HOST).and_then(|h| h.to_str().ok());
                host.is_some_and(|h| names.iter().any(|n| n.eq_ignore_ascii_case(h)))
            }
        }
    }
}

const FOREIGN_HOST: &str = "this server answers only to its own address (Host header refused)\n";

impl App {
    /// A message came from `tab`: its lease (if it drives) starts again.
    fn heard(&self, tab: u64) {
        lock(&self.heard).insert(tab, Instant::now());
    }

    /// `tab` closed.
    fn forget(&self, tab: u64) {
        lock(&self.heard).remove(&tab);
    }

    /// Ends the control of a driving tab silent for more than [`LEASE`]
    /// (releasing a watching tab's control changes nothing).
    fn lapse(&self) {
        // Held throughout: a tab heard from meanwhile is not released.
        let heard = lock(&self.heard);
        for (&tab, at) in heard.iter() {
            if at.elapsed() > LEASE {
                let _ = self.console.handle(tab, Request::ReleaseControl {}, Box::new(|_| {}));
            }
        }
    }

    /// Whether the request carries the token (always, without one).
    fn admitted(&self, query: &HashMap<String, String>) -> bool {
        let Some(token) = &self.token else { return true };
        let given = query.get("token").map_or(&[][..], |t| t.as_bytes());
        // Compared in full whatever differs first: the time says nothing of the token.
        given.len() == token.len() && given.iter().zip(token.as_bytes()).fold(0u8, |acc, (a, b)| acc | (a ^ b)) == 0
    }
}

/// Stops a task when dropped: the state's ticker ends with the server,
/// however the server's future ends (done, or dropped by its caller).
struct AbortOnDrop(tokio::task::JoinHandle<()>);

impl Drop for AbortOnDrop {
    fn drop(&mut self) {
        self.0.abort();
    }
}

/// Serves the console on `listener` until the future is dropped (open
/// websockets would keep a graceful shutdown waiting for ever). The caller
/// has checked the address ([`check_listen`]).
pub async fn serve(console: Arc<Console>, listener: TcpListener, token: Option<String>) -> std::io::Result<()> {
    let (tx, rx) = watch::channel::<Arc<str>>(Arc::from(console.snapshot()));
    let _ticker = AbortOnDrop(tokio::spawn({
        let console = Arc::clone(&console);
        async move {
            let mut tick = tokio::time::interval(STATE_PERIOD);
            tick.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Skip);
            let predicted = console.predicted();
            loop {
                // A new body goes out at once (a slider's move reaches the
                // drawing a tick sooner), the rest every tick.
                tokio::select! {
                    _ = tick.tick() => {}
                    () = predicted.notified() => {}
                }
                tx.send_replace(Arc::from(console.snapshot()));
                tokio::time::sleep(MIN_STATE_GAP).await;
            }
        }
    }));
    let hosts = Hosts::of(listener.local_addr()?);
    let app =
        App { console, token: token.map(Arc::from), state: rx, hosts, heard: Arc::default(), stops: Arc::default() };
    let _lease = AbortOnDrop(tokio::spawn({
        let app = app.clone();
        async move {
            let mut tick = tokio::time::interval(LEASE / 20);
            loop {
                tick.tick().await;
                app.lapse();
            }
        }
    }));
    let router = Router::new().route("/", get(page)).route("/ws", get(socket)).with_state(app);
    axum::serve(listener, router).await
}

async fn page(State(app): State<App>, Query(query): Query<HashMap<String, String>>, headers: HeaderMap) -> Response {
    if !app.hosts.admit(&headers) {
        return (StatusCode::FORBIDDEN, FOREIGN_HOST).into_response();
    }
    if !app.admitted(&query) {
        return (StatusCode::UNAUTHORIZED, "a token is needed: open the URL leech serve printed\n").into_response();
    }
    let html = INDEX.replace("/*STYLE*/", STYLE).replace("/*SCRIPT*/", SCRIPT);
    let mut response = Html(html).into_response();
    let headers = response.headers_mut();
    // The page moves a robot: no other site may frame it (clickjacking).
    headers.insert(header::X_FRAME_OPTIONS, header::HeaderValue::from_static("DENY"));
    headers.insert(header::CACHE_CONTROL, header::HeaderValue::from_static("no-store"));
    response
}

/// Whether a websocket's `Origin` (if any; programs send none) is this server.
fn same_origin(headers: &HeaderMap) -> bool {
    let Some(origin) = headers.get(header::ORIGIN) else { return true };
    let host = headers.get(header::HOST).and_then(|h| h.to_str().ok());
    let origin = origin.to_str().ok().and_then(|o| o.strip_prefix("http://").or_else(|| o.strip_prefix("https://")));
    matches!((origin, host), (Some(o), Some(h)) if o == h)
}

async fn socket(
    State(app): State<App>,
    Query(query): Query<HashMap<String, String>>,
    headers: HeaderMap,
    upgrade: WebSocketUpgrade,
) -> Response {
    if !app.hosts.admit(&headers) {
        return (StatusCode::FORBIDDEN, FOREIGN_HOST).into_response();
    }
    if !app.admitted(&query) {
        return (StatusCode::UNAUTHORIZED, "a token is needed\n").into_response();
    }
    if !same_origin(&headers) {
        return (StatusCode::FORBIDDEN, "the websocket is for this server's own page\n").into_response();
    }
    upgrade
        .max_message_size(4 * MAX_REQUEST_BYTES)
        .max_frame_size(4 * MAX_REQUEST_BYTES)
        .on_upgrade(move |ws| session(app, ws))
}

/// One tab's session: hello, then states, replies and refusals, until the
/// tab closes, stops reading ([`SEND_DEADLINE`]) or stops answering
/// ([`SILENCE`]).
async fn session(app: App, mut ws: WebSocket) {
    let console = Arc::clone(&app.console);
    let tab = console.connect();
    app.heard(tab);
    let mut state = app.state.clone();
    let (later_tx, mut later_rx) = mpsc::unbounded_channel::<String>();
    let text = |v: serde_json::Value| Message::Text(v.to_string().into());
    let mut ping = tokio::time::interval(PING_PERIOD);
    ping.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    let mut last_heard = Instant::now();
    // The tab's requests, carried out in order by a worker of its own; its
    // answers come back with the later ones.
    let (queue, queued) = mpsc::channel::<(u64, Request)>(QUEUE);
    let _worker = AbortOnDrop(tokio::spawn(work(app.clone(), tab, queued, later_tx.clone())));
    if put(&mut ws, text(console.hello(tab))).await {
        loop {
            tokio::select! {
                incoming = ws.recv() => {
                    last_heard = Instant::now();
                    let text_in = match incoming {
                        Some(Ok(Message::Text(t))) => t.to_string(),
                        Some(Ok(Message::Binary(_))) => {
                            app.heard(tab);
                            let r = Refusal::new("message", "kind", "binary", "text (JSON)", "binary messages are not read");
                            if !put(&mut ws, text(refusal(&r))).await { break }
                            continue;
                        }
                        // The browser answers pings itself, even when the page hangs:
                        // they keep the socket, not the control.
                        Some(Ok(Message::Ping(_) | Message::Pong(_))) => continue,
                        Some(Ok(Message::Close(_))) | Some(Err(_)) | None => break,
                    };
                    app.heard(tab);
                    let reply = match messages::parse(&text_in) {
                        Ok(None) => Some(json!({ "type": "pong" })),
                        // A stop goes ahead of the tab's queue, and cancels the moves
                        // queued (by any tab) before it.
                        Ok(Some(Request::Stop {})) => {
                            app.stops.fetch_add(1, Ordering::SeqCst);
                            Some(run(&console, tab, Request::Stop {}, later_tx.clone()).await)
                        }
                        Ok(Some(request)) => match queue.try_send((app.stops.load(Ordering::SeqCst), request)) {
                            Ok(()) => None,
                            Err(mpsc::error::TrySendError::Full((_, r))) => Some(refusal(&Refusal::new(
                                r.name(),
                                "queue",
                                format!("{QUEUE} requests waiting"),
                                format!("at most {QUEUE} requests waiting"),
                                "too many requests at once: wait for their answers",
                            ))),
                            Err(mpsc::error::TrySendError::Closed(_)) => break,
                        },
                        Err(r) => Some(refusal(&r)),
                    };
                    if let Some(reply) = reply {
                        if !put(&mut ws, text(reply)).await { break }
                    }
                }
                changed = state.changed() => {
                    if changed.is_err() { break }
                    let s = state.borrow_and_update().to_string();
                    if !put(&mut ws, Message::Text(s.into())).await { break }
                }
                Some(later) = later_rx.recv() => {
                    if !put(&mut ws, Message::Text(later.into())).await { break }
                }
                _ = ping.tick() => {
                    if last_heard.elapsed() > SILENCE { break }
                    if !put(&mut ws, Message::Ping(Vec::new().into())).await { break }
                }
            }
        }
    }
    app.forget(tab);
    console.disconnect(tab);
}

/// Carries out one tab's queued requests in order, each tagged with the
/// number of stops asked before it: a move (`set_lengths`, `jog`, `stride`,
/// `execute`) a stop came after is refused, and one a stop came during is
/// stopped again once done, so that nothing moves after a stop.
async fn work(app: App, tab: u64, mut queued: mpsc::Receiver<(u64, Request)>, out: mpsc::UnboundedSender<String>) {
    while let Some((stops, request)) = queued.recv().await {
        let moves = matches!(
            request,
            Request::SetLengths { .. } | Request::Jog { .. } | Request::Stride { .. } | Request::Execute { .. }
        );
        let reply = if moves && app.stops.load(Ordering::SeqCst) != stops {
            refusal(&Refusal::new(
                request.name(),
                "stop",
                "asked before a stop",
                "a request sent after the stop",
                "cancelled: a stop came after it",
            ))
        } else {
            let reply = run(&app.console, tab, request, out.clone()).await;
            if moves && app.stops.load(Ordering::SeqCst) != stops {
                let _ = run(&app.console, tab, Request::Stop {}, out.clone()).await;
            }
            reply
        };
        if out.send(reply.to_string()).is_err() {
            break;
        }
    }
}

/// Sends one message within [`SEND_DEADLINE`]: false if the socket failed
/// or the tab does not read (its queue stays full), and the session ends.
async fn put(ws: &mut WebSocket, message: Message) -> bool {
    matches!(tokio::time::timeout(SEND_DEADLINE, ws.send(message)).await, Ok(Ok(())))
}

/// Judges one request off the async threads (link commands wait for the
/// controller's answer): the answer or the refusal.
async fn run(
    console: &Arc<Console>,
    tab: u64,
    request: Request,
    later_tx: mpsc::UnboundedSender<String>,
) -> serde_json::Value {
    let console = Arc::clone(console);
    let later: crate::console::Later = Box::new(move |v| {
        let _ = later_tx.send(v.to_string());
    });
    match tokio::task::spawn_blocking(move || console.handle(tab, request, later)).await {
        Ok(Ok(v)) => v,
        Ok(Err(r)) => refusal(&r),
        Err(_) => json!({ "type": "error", "message": "the request failed" }),
    }
}

/// A lock, even if a thread panicked holding it (the map stays usable).
fn lock<T>(m: &Mutex<T>) -> MutexGuard<'_, T> {
    m.lock().unwrap_or_else(std::sync::PoisonError::into_inner)
}

fn refusal(r: &Refusal) -> serde_json::Value {
    json!({
        "type": "error",
        "request": r.request,
        "field": r.field,
        "value": r.value,
        "allowed": r.allowed,
        "message": r.message,
    })
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn another_address_needs_a_token() {
        let loopback: SocketAddr = "127.0.0.1:8080".parse().unwrap();
        let any: SocketAddr = "0.0.0.0:8080".parse().unwrap();
        assert_eq!(check_listen(loopback, None), Ok(()));
        assert_eq!(check_listen(any, None), Err(ListenError::NeedsToken(any)));
        assert_eq!(check_listen(any, Some("short")), Err(ListenError::BadToken(5)));
        assert_eq!(check_listen(any, Some("a-long_token.1")), Ok(()));
    }

    #[test]
    fn a_foreign_origin_is_refused() {
        let mut h = HeaderMap::new();
        assert!(same_origin(&h));
        h.insert(header::HOST, "127.0.0.1:8080".parse().unwrap());
        h.insert(header::ORIGIN, "http://127.0.0.1:8080".parse().unwrap());
        assert!(same_origin(&h));
        h.insert(header::ORIGIN, "http://evil.example".parse().unwrap());
        assert!(!same_origin(&h));
    }

    #[test]
    fn only_the_servers_own_names_are_hosts() {
        let with = |host: &str| {
            let mut h = HeaderMap::new();
            h.insert(header::HOST, host.parse().unwrap());
            h
        };
        let local = Hosts::of("127.0.0.1:8080".parse().unwrap());
        for host in ["127.0.0.1:8080", "localhost:8080", "LocalHost:8080", "[::1]:8080"] {
            assert!(local.admit(&with(host)), "{host}");
        }
        for host in ["evil.example:8080", "127.0.0.1:8081", "localhost", "127.0.0.1.evil.example:8080"] {
            assert!(!local.admit(&with(host)), "{host}");
        }
        assert!(!local.admit(&HeaderMap::new()));
        let lan = Hosts::of("192.168.1.5:8080".parse().unwrap());
        assert!(lan.admit(&with("192.168.1.5:8080")));
        assert!(!lan.admit(&with("localhost:8080")));
        let web = Hosts::of("127.0.0.1:80".parse().unwrap());
        assert!(web.admit(&with("localhost")));
        assert!(Hosts::of("0.0.0.0:8080".parse().unwrap()).admit(&with("robot.lan:8080")));
    }
}
