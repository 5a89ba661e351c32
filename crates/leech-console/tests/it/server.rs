//! The server's defences: a foreign `Host` (DNS rebinding) refused, a
//! silent driver's control lapsing, and a stop never waiting behind a
//! tab's queued requests.

use std::net::SocketAddr;
use std::time::{Duration, Instant};

use futures_util::{SinkExt, StreamExt};
use leech_console::server;
use tokio::io::{AsyncReadExt, AsyncWriteExt};
use tokio::net::TcpStream;
use tokio_tungstenite::tungstenite::Message;

use serde_json::json;

use crate::{answer, ask, connect, held, measured, start, state, until, LIMIT};

/// Sends `request` as is and returns the whole response (the server closes it).
async fn raw(addr: SocketAddr, request: String) -> String {
    let mut s = TcpStream::connect(addr).await.unwrap();
    s.write_all(request.as_bytes()).await.unwrap();
    let mut text = Vec::new();
    // A websocket accepted stays open: read what comes within a moment.
    let _ = tokio::time::timeout(Duration::from_millis(500), s.read_to_end(&mut text)).await;
    String::from_utf8_lossy(&text).into_owned()
}

fn page_request(host: &str) -> String {
    format!("GET / HTTP/1.1\r\nHost: {host}\r\nConnection: close\r\n\r\n")
}

fn socket_request(host: &str) -> String {
    format!(
        "GET /ws HTTP/1.1\r\nHost: {host}\r\nOrigin: http://{host}\r\nConnection: Upgrade\r\nUpgrade: websocket\r\n\
         Sec-WebSocket-Version: 13\r\nSec-WebSocket-Key: dGhlIHNhbXBsZSBub25jZQ==\r\n\r\n"
    )
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_foreign_host_is_refused_the_page_and_the_socket() {
    tokio::time::timeout(LIMIT, async {
        let running = start(None).await;
        let addr = running.addr;
        let port = addr.port();
        // A site whose name resolves to 127.0.0.1: its own origin, its own Host.
        let evil = format!("evil.example:{port}");
        let page = raw(addr, page_request(&evil)).await;
        assert!(page.starts_with("HTTP/1.1 403"), "{page}");
        assert!(!page.contains("leech console"), "{page}");
        let socket = raw(addr, socket_request(&evil)).await;
        assert!(socket.starts_with("HTTP/1.1 403"), "{socket}");
        // The server's own names are served.
        for host in [addr.to_string(), format!("localhost:{port}")] {
            let page = raw(addr, page_request(&host)).await;
            assert!(page.starts_with("HTTP/1.1 200") && page.contains("leech console"), "{host}: {page}");
            let socket = raw(addr, socket_request(&host)).await;
            assert!(socket.starts_with("HTTP/1.1 101"), "{host}: {socket}");
        }
    })
    .await
    .expect("within the limit");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_silent_drivers_control_lapses_and_another_tab_takes_it() {
    tokio::time::timeout(LIMIT, async {
        let running = start(None).await;
        let (mut a, a_tab) = connect(running.addr).await;
        let (mut b, _) = connect(running.addr).await;
        assert_eq!(ask(&mut a, r#"{"type":"take_control"}"#).await["type"], "ok");
        // A keeps reading (so it is not dropped as a tab that does not read)...
        let (mut a_out, mut a_in) = a.split();
        let reader = tokio::spawn(async move { while let Some(Ok(_)) = a_in.next().await {} });
        // ...and pings every 2 s, as the page does while it drives: it keeps control past the lease.
        let kept = Instant::now();
        while kept.elapsed() < server::LEASE + Duration::from_secs(2) {
            a_out.send(Message::Text(r#"{"type":"ping"}"#.into())).await.unwrap();
            tokio::time::sleep(Duration::from_secs(2)).await;
        }
        let refused = ask(&mut b, r#"{"type":"take_control"}"#).await;
        assert_eq!(
            (refused["type"].as_str(), refused["field"].as_str()),
            (Some("error"), Some("control")),
            "{refused}"
        );
        // Then A goes silent (a hung page): after the lease, B may take control.
        let silent = Instant::now();
        loop {
            let reply = ask(&mut b, r#"{"type":"take_control"}"#).await;
            if reply["type"] == "ok" {
                break;
            }
            assert!(silent.elapsed() < server::LEASE + Duration::from_secs(3), "A still drives: {reply}");
            tokio::time::sleep(Duration::from_millis(250)).await;
        }
        assert!(silent.elapsed() >= server::LEASE - Duration::from_secs(2), "lapsed after {:?}", silent.elapsed());
        let s = until(&mut b, Duration::from_secs(2), |s| s["driver"] != a_tab).await;
        assert!(s["driver"].is_u64(), "{s}");
        reader.abort();
    })
    .await
    .expect("within the limit");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_stop_goes_ahead_of_a_backlog_of_jogs_and_the_motors_stop() {
    tokio::time::timeout(LIMIT, async {
        let running = start(None).await;
        let (mut ws, _) = connect(running.addr).await;
        held(&mut ws).await;
        assert_eq!(ask(&mut ws, r#"{"type":"take_control"}"#).await["type"], "ok");
        const JOGS: usize = 300;
        for i in 0..JOGS {
            let delta = if i % 2 == 0 { 2 } else { -1 };
            let jog = json!({"type": "jog", "tube": 1, "delta_mm": delta}).to_string();
            ws.feed(Message::Text(jog.into())).await.unwrap();
        }
        ws.flush().await.unwrap();
        let sent = Instant::now();
        ws.send(Message::Text(r#"{"type":"stop"}"#.into())).await.unwrap();
        let mut before = 0;
        let stopped = loop {
            let a = answer(&mut ws).await;
            if a["request"] == "stop" {
                break a;
            }
            assert_eq!(a["request"], "jog", "{a}");
            before += 1;
        };
        let took = sent.elapsed();
        assert_eq!(stopped["type"], "ok", "{stopped}");
        assert!(before < JOGS, "the stop came after all {JOGS} jogs' answers, {took:?} after it was sent");
        assert!(took < Duration::from_millis(500), "the stop's answer took {took:?}");
        // The jogs left are answered (refused: a stop came after them), and nothing moves.
        for _ in before..JOGS {
            let a = answer(&mut ws).await;
            assert_eq!(a["request"], "jog", "{a}");
        }
        tokio::time::sleep(Duration::from_millis(300)).await;
        let first = state(&mut ws).await;
        tokio::time::sleep(Duration::from_millis(300)).await;
        let second = state(&mut ws).await;
        assert_eq!(second["telemetry"]["moving"], json!([false, false, false]), "{}", second["telemetry"]);
        for i in 0..3 {
            assert!((measured(&first, i) - measured(&second, i)).abs() < 1e-4, "tube {i} moves after the stop");
        }
    })
    .await
    .expect("within the limit");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_tab_that_neither_reads_nor_answers_is_dropped() {
    tokio::time::timeout(LIMIT, async {
        let running = start(None).await;
        let (mut a, _) = connect(running.addr).await;
        let (mut b, _) = connect(running.addr).await;
        assert_eq!(ask(&mut a, r#"{"type":"take_control"}"#).await["type"], "ok");
        until(&mut b, Duration::from_secs(5), |s| s["tabs"] == 2).await;
        // A hangs: it is kept open but never read again (no pongs, a full queue).
        let within = server::SILENCE + server::PING_PERIOD + server::SEND_DEADLINE + Duration::from_secs(5);
        let s = until(&mut b, within, |s| s["tabs"] == 1).await;
        assert!(s["driver"].is_null(), "{s}");
        drop(a);
    })
    .await
    .expect("within the limit");
}
