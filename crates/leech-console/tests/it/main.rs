//! The console's server against the simulated robot, through a websocket
//! client on the loopback interface: the state's rate, a command moving
//! the robot, one driver at a time, and a hostile client refused.

use std::net::SocketAddr;
use std::sync::Arc;
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use leech::robot::Robot;
use leech::stride::Scenario;
use leech_console::{Console, Setup, Source};
use serde_json::{json, Value};
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;
use tokio_tungstenite::{MaybeTlsStream, WebSocketStream};

mod rules;
mod server;

pub(crate) type Ws = WebSocketStream<MaybeTlsStream<TcpStream>>;

/// Each test's bound: a hung server fails the test, it does not hang CI.
pub(crate) const LIMIT: Duration = Duration::from_secs(90);

/// A console on the simulated robot in the crawl-floor scenario, served on
/// 127.0.0.1 at a free port; the server stops when this is dropped.
pub(crate) struct Running {
    pub(crate) addr: SocketAddr,
    server: tokio::task::JoinHandle<()>,
}

impl Drop for Running {
    fn drop(&mut self) {
        self.server.abort();
    }
}

pub(crate) async fn start(token: Option<&str>) -> Running {
    let scenario = Scenario::builtin("crawl-floor").unwrap();
    let setup = Setup {
        robot: Robot::builtin(),
        scene: scenario.scene,
        start: scenario.start,
        goal: Some(scenario.goal),
        source: Source::Simulated,
    };
    let console = tokio::task::spawn_blocking(|| Console::start(setup)).await.unwrap().unwrap();
    let listener = tokio::net::TcpListener::bind("127.0.0.1:0").await.unwrap();
    let addr = listener.local_addr().unwrap();
    let token = token.map(str::to_string);
    let server = tokio::spawn(async move {
        let _ = leech_console::server::serve(Arc::new(console), listener, token).await;
    });
    Running { addr, server }
}

pub(crate) async fn connect(addr: SocketAddr) -> (Ws, u64) {
    let (mut ws, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/ws")).await.unwrap();
    let hello = next(&mut ws, |m| m["type"] == "hello").await;
    (ws, hello["tab"].as_u64().unwrap())
}

/// The next message that `pick` accepts (others skipped).
pub(crate) async fn next(ws: &mut Ws, pick: impl Fn(&Value) -> bool) -> Value {
    loop {
        let msg = ws.next().await.expect("the socket stays open").expect("a message");
        if let Message::Text(t) = msg {
            let v: Value = serde_json::from_str(&t).expect("the server sends JSON");
            if pick(&v) {
                return v;
            }
        }
    }
}

/// The answer to the last request (states skipped).
pub(crate) async fn answer(ws: &mut Ws) -> Value {
    next(ws, |m| m["type"] == "ok" || m["type"] == "error").await
}

pub(crate) async fn ask(ws: &mut Ws, text: &str) -> Value {
    ws.send(Message::Text(text.into())).await.unwrap();
    answer(ws).await
}

pub(crate) async fn state(ws: &mut Ws) -> Value {
    next(ws, |m| m["type"] == "state").await
}

/// The first state that `done` accepts, within `within`.
pub(crate) async fn until(ws: &mut Ws, within: Duration, done: impl Fn(&Value) -> bool) -> Value {
    let end = Instant::now() + within;
    loop {
        let s = state(ws).await;
        if done(&s) {
            return s;
        }
        assert!(Instant::now() < end, "the state never came: last {}", s["telemetry"]);
    }
}

pub(crate) fn measured(s: &Value, i: usize) -> f64 {
    s["telemetry"]["lengths_m"][i].as_f64().unwrap_or(f64::NAN)
}

/// Waits for the simulated robot to hold with its rear cup (its pump is
/// switched on at start) and for the model to have a body.
pub(crate) async fn held(ws: &mut Ws) -> Value {
    until(ws, Duration::from_secs(20), |s| s["holding"][0] == true && s["prediction"]["body"].is_object()).await
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn the_state_arrives_at_30_hz_and_a_lengths_command_moves_the_robot() {
    tokio::time::timeout(LIMIT, async {
        let running = start(None).await;
        let (mut ws, _) = connect(running.addr).await;
        let first = held(&mut ws).await;
        // The rate: states in one second.
        let started = Instant::now();
        let mut n = 0;
        while started.elapsed() < Duration::from_secs(1) {
            state(&mut ws).await;
            n += 1;
        }
        assert!(n >= 30, "{n} states in a second");

        assert_eq!(ask(&mut ws, r#"{"type":"take_control"}"#).await["type"], "ok");
        let before = measured(&first, 0);
        let target = before + 0.01;
        let reply =
            ask(&mut ws, &json!({"type": "set_lengths", "lengths_m": [target, before, before]}).to_string()).await;
        assert_eq!(reply["type"], "ok", "{reply}");
        // 10 mm at 20 mm/s, and the model's body follows.
        let moved = until(&mut ws, Duration::from_secs(10), |s| {
            (measured(s, 0) - target).abs() < 5e-4
                && s["prediction"]["body"]["lengths_m"][0].as_f64().is_some_and(|la| (la - target).abs() < 1e-3)
        })
        .await;
        assert!((moved["commanded_m"][0].as_f64().unwrap() - target).abs() < 1e-6);
    })
    .await
    .expect("within the limit");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_hostile_client_is_refused_and_nothing_changes() {
    tokio::time::timeout(LIMIT, async {
        let running = start(None).await;
        let (mut driver, _) = connect(running.addr).await;
        let (mut watcher, watcher_tab) = connect(running.addr).await;
        let before = held(&mut driver).await;
        assert_eq!(ask(&mut driver, r#"{"type":"take_control"}"#).await["type"], "ok");
        let hostile = [
            ("{not json", "json"),
            ("[1, 2]", "type"),
            (r#"{"type":"fly"}"#, "type"),
            (r#"{"type":"stop","force":true}"#, "fields"),
            (r#"{"type":"set_lengths","lengths_m":[0.9,0.2,0.2]}"#, "lengths_m[0]"),
            (r#"{"type":"set_lengths","lengths_m":[0.2,-0.1,0.2]}"#, "lengths_m[1]"),
            (r#"{"type":"set_lengths","lengths_m":[NaN,0.2,0.2]}"#, "json"),
            (r#"{"type":"set_lengths","lengths_m":[1e999,0.2,0.2]}"#, "json"),
            (r#"{"type":"set_lengths","lengths_m":[0.2,0.2]}"#, "fields"),
            (r#"{"type":"jog","tube":7,"delta_mm":1}"#, "tube"),
            (r#"{"type":"jog","tube":1,"delta_mm":1e300}"#, "delta_mm"),
            (r#"{"type":"jog","tube":1,"delta_mm":-50.5}"#, "delta_mm"),
            // The rear cup is the only one holding: letting go is a fall.
            (r#"{"type":"pump","cup":"rear","on":false}"#, "on"),
            (r#"{"type":"stride","phase":"release_rear"}"#, "phase"),
            (r#"{"type":"stride","phase":"fly"}"#, "phase"),
            (r#"{"type":"stride","phase":"push","lengths_m":[0.2,0.5]}"#, "lengths_m[1]"),
            (r#"{"type":"execute","mode":"all"}"#, "plan"),
            (r#"{"type":"plan","goal_m":[0.5,0.0],"tolerance_m":-1}"#, "tolerance_m"),
            (r#"{"type":"plan","goal_m":[0.5,0.0]}"#, "goal_m"),
            (r#"{"type":"plan","scenario":"climb-wall-up"}"#, "scenario"),
            (r#"{"type":"plan","scenario":"no-such"}"#, "scenario"),
        ];
        for (text, field) in hostile {
            let reply = ask(&mut driver, text).await;
            assert_eq!(reply["type"], "error", "{text} -> {reply}");
            assert_eq!(reply["field"], field, "{text} -> {reply}");
            for key in ["request", "value", "allowed", "message"] {
                assert!(reply[key].as_str().is_some_and(|s| !s.is_empty()), "{text} -> {reply}: no {key}");
            }
        }
        let long = format!(r#"{{"type":"stop","pad":"{}"}}"#, "x".repeat(5000));
        assert_eq!(ask(&mut driver, &long).await["field"], "length");

        // The watcher may not drive nor take control while another tab drives.
        for text in [
            r#"{"type":"set_lengths","lengths_m":[0.25,0.25,0.25]}"#,
            r#"{"type":"jog","tube":1,"delta_mm":5}"#,
            r#"{"type":"pump","cup":"front","on":true}"#,
            r#"{"type":"stride","phase":"push","lengths_m":[0.25,0.25]}"#,
            r#"{"type":"take_control"}"#,
        ] {
            let reply = ask(&mut watcher, text).await;
            assert_eq!((reply["type"].as_str(), reply["field"].as_str()), (Some("error"), Some("control")), "{reply}");
            assert_eq!(reply["value"], format!("tab {watcher_tab}"));
        }

        // Nothing changed: same lengths, nothing moving, the rear cup holds, its pump on.
        tokio::time::sleep(Duration::from_millis(300)).await;
        let after = state(&mut driver).await;
        for i in 0..3 {
            assert!((measured(&after, i) - measured(&before, i)).abs() < 2e-4, "tube {i} moved");
        }
        assert_eq!(after["telemetry"]["moving"], json!([false, false, false]));
        assert_eq!(after["telemetry"]["pumps_on"], json!([true, false]));
        assert_eq!(after["holding"], json!([true, false]));
        // The release the interlock refuses is greyed out on the page, with the reason.
        let phases = after["phases"].as_array().unwrap();
        let release = phases.iter().find(|p| p["phase"] == "release_rear").unwrap();
        assert_eq!(release["allowed"], false);
        assert!(release["reason"].as_str().unwrap().contains("would fall"), "{release}");
    })
    .await
    .expect("within the limit");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn control_is_released_when_the_driving_tab_closes() {
    tokio::time::timeout(LIMIT, async {
        let running = start(None).await;
        let (mut a, a_tab) = connect(running.addr).await;
        let (mut b, _) = connect(running.addr).await;
        assert_eq!(ask(&mut a, r#"{"type":"take_control"}"#).await["type"], "ok");
        until(&mut b, Duration::from_secs(5), |s| s["driver"] == a_tab).await;
        assert_eq!(ask(&mut b, r#"{"type":"take_control"}"#).await["type"], "error");
        a.close(None).await.unwrap();
        drop(a);
        until(&mut b, Duration::from_secs(5), |s| s["driver"].is_null()).await;
        assert_eq!(ask(&mut b, r#"{"type":"take_control"}"#).await["type"], "ok");
        // Any tab may stop.
        assert_eq!(ask(&mut b, r#"{"type":"stop"}"#).await["type"], "ok");
    })
    .await
    .expect("within the limit");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_token_is_required_when_given() {
    tokio::time::timeout(LIMIT, async {
        let running = start(Some("secret-token")).await;
        let addr = running.addr;
        let refused = tokio_tungstenite::connect_async(format!("ws://{addr}/ws")).await;
        assert!(refused.is_err(), "a socket without the token");
        let wrong = tokio_tungstenite::connect_async(format!("ws://{addr}/ws?token=secret-tokem")).await;
        assert!(wrong.is_err(), "a socket with a wrong token");
        let (mut ws, _) = tokio_tungstenite::connect_async(format!("ws://{addr}/ws?token=secret-token")).await.unwrap();
        next(&mut ws, |m| m["type"] == "hello").await;
        // The page too.
        let page = |path: &str| {
            let request = format!("GET {path} HTTP/1.1\r\nHost: {addr}\r\nConnection: close\r\n\r\n");
            async move {
                use tokio::io::{AsyncReadExt, AsyncWriteExt};
                let mut s = TcpStream::connect(addr).await.unwrap();
                s.write_all(request.as_bytes()).await.unwrap();
                let mut text = String::new();
                s.read_to_string(&mut text).await.unwrap();
                text
            }
        };
        assert!(page("/").await.starts_with("HTTP/1.1 401"));
        let ok = page("/?token=secret-token").await;
        assert!(ok.starts_with("HTTP/1.1 200") && ok.contains("leech console"), "{ok}");
        // A non-loopback address without a token is refused before anything listens.
        let any: SocketAddr = "0.0.0.0:8080".parse().unwrap();
        assert!(leech_console::server::check_listen(any, None).is_err());
    })
    .await
    .expect("within the limit");
}

/// The first state in which the run is over and `done` holds.
pub(crate) async fn settled(ws: &mut Ws, within: Duration, done: impl Fn(&Value) -> bool) -> Value {
    until(ws, within, |s| s["run"]["busy"] == false && done(s)).await
}

pub(crate) fn allowed(s: &Value, phase: &str) -> bool {
    s["phases"].as_array().unwrap().iter().any(|p| p["phase"] == phase && p["allowed"] == true)
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stride_by_hand_passes_the_interlock_on_the_models_evidence() {
    tokio::time::timeout(Duration::from_secs(150), async {
        let running = start(None).await;
        let (mut ws, _) = connect(running.addr).await;
        held(&mut ws).await;
        assert_eq!(ask(&mut ws, r#"{"type":"take_control"}"#).await["type"], "ok");
        let planning = ask(&mut ws, r#"{"type":"plan","goal_m":[0.1,0.0],"tolerance_m":0.05}"#).await;
        assert_eq!(planning["type"], "ok", "{planning}");
        let plan = next(&mut ws, |m| m["type"] == "plan").await;
        assert_eq!(plan["status"], "reached", "{}", plan["reason"]);
        let phases: Vec<&str> =
            plan["steps"].as_array().unwrap().iter().map(|s| s["phase"].as_str().unwrap()).collect();
        assert_eq!(phases[..3], ["start", "push", "attach_front"]);
        // The plan's start and push through the executor, one step at a time.
        for n in 1..=2 {
            assert_eq!(ask(&mut ws, r#"{"type":"execute","mode":"step"}"#).await["type"], "ok");
            let s = settled(&mut ws, Duration::from_secs(30), |s| s["run"]["next_step"] == n).await;
            assert!(s["run"]["error"].is_null(), "{}", s["run"]);
        }
        // Then by hand: the model says the front cup lies flush, so it may attach.
        let s = until(&mut ws, Duration::from_secs(5), |s| allowed(s, "attach_front")).await;
        assert_eq!(s["prediction"]["body"]["cups"][1]["flush"], true);
        assert_eq!(ask(&mut ws, r#"{"type":"stride","phase":"attach_front"}"#).await["type"], "ok");
        settled(&mut ws, Duration::from_secs(10), |s| s["holding"] == json!([true, true])).await;
        // Both hold: the model finds the front cup's factor alone, and the release passes.
        let s = until(&mut ws, Duration::from_secs(10), |s| allowed(s, "release_rear")).await;
        let alone = s["prediction"]["body"]["cups"][0]["other_after_release"].as_f64().unwrap();
        assert!(alone >= 1.5, "the front cup alone: {alone}");
        assert_eq!(ask(&mut ws, r#"{"type":"stride","phase":"release_rear"}"#).await["type"], "ok");
        settled(&mut ws, Duration::from_secs(10), |s| s["holding"] == json!([false, true])).await;
        // Now the front cup is the last: switching its pump off is refused.
        let refused = ask(&mut ws, r#"{"type":"pump","cup":"front","on":false}"#).await;
        assert_eq!((refused["type"].as_str(), refused["field"].as_str()), (Some("error"), Some("on")), "{refused}");
        let s = state(&mut ws).await;
        assert_eq!(s["telemetry"]["pumps_on"][1], true);
    })
    .await
    .expect("within the limit");
}
