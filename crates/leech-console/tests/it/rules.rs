//! The console's rules against the simulated robot: what a run, a plan
//! and a free cup's pump allow.

use std::time::Duration;

use serde_json::json;

use crate::{ask, connect, held, measured, settled, start, state, LIMIT};

/// A hand push `mm` longer than the measured lengths: a run that lasts
/// about `mm / 20` s.
fn long_push(s: &serde_json::Value, mm: f64) -> String {
    let (la, lb) = (measured(s, 0), measured(s, 1));
    json!({"type": "stride", "phase": "push", "lengths_m": [la + mm / 1e3, lb + mm / 1e3]}).to_string()
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn lengths_and_jogs_are_refused_while_a_run_goes_on() {
    tokio::time::timeout(LIMIT, async {
        let running = start(None).await;
        let (mut ws, _) = connect(running.addr).await;
        let s = held(&mut ws).await;
        assert_eq!(ask(&mut ws, r#"{"type":"take_control"}"#).await["type"], "ok");
        let push = ask(&mut ws, &long_push(&s, 40.0)).await;
        assert_eq!(push["type"], "ok", "{push}");
        let (la, lb) = (measured(&s, 0), measured(&s, 1));
        for text in [
            json!({"type": "set_lengths", "lengths_m": [la, lb, lb]}).to_string(),
            r#"{"type":"jog","tube":1,"delta_mm":-5}"#.to_string(),
        ] {
            let reply = ask(&mut ws, &text).await;
            assert_eq!((reply["type"].as_str(), reply["field"].as_str()), (Some("error"), Some("run")), "{reply}");
        }
        // Stop is always allowed.
        assert_eq!(ask(&mut ws, r#"{"type":"stop"}"#).await["type"], "ok");
        settled(&mut ws, Duration::from_secs(20), |_| true).await;
        let s = state(&mut ws).await;
        // The run ended on the stop (before or during its move).
        assert!(s["run"]["error"].is_string(), "{}", s["run"]);
    })
    .await
    .expect("within the limit");
}
