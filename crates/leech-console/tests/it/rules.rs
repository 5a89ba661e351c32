//! The console's rules against the simulated robot: what a run, a plan
//! and a free cup's pump allow.

use std::time::Duration;

use futures_util::SinkExt;
use serde_json::json;
use tokio_tungstenite::tungstenite::Message;

use crate::{answer, ask, connect, held, measured, next, settled, start, state, LIMIT};

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

/// Asks for a plan to a point near the start and waits for it.
async fn plan(ws: &mut crate::Ws) -> serde_json::Value {
    let planning = ask(ws, r#"{"type":"plan","goal_m":[0.1,0.0],"tolerance_m":0.05}"#).await;
    assert_eq!(planning["type"], "ok", "{planning}");
    let plan = next(ws, |m| m["type"] == "plan").await;
    assert_eq!(plan["status"], "reached", "{}", plan["reason"]);
    plan
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_plan_is_executed_only_from_the_state_it_was_planned_in() {
    tokio::time::timeout(Duration::from_secs(150), async {
        let running = start(None).await;
        let (mut ws, _) = connect(running.addr).await;
        held(&mut ws).await;
        assert_eq!(ask(&mut ws, r#"{"type":"take_control"}"#).await["type"], "ok");
        plan(&mut ws).await;
        // A manual command (here a pump, which moves nothing) drops the plan.
        assert_eq!(ask(&mut ws, r#"{"type":"pump","cup":"front","on":false}"#).await["type"], "ok");
        let refused = ask(&mut ws, r#"{"type":"execute","mode":"step"}"#).await;
        assert_eq!((refused["type"].as_str(), refused["field"].as_str()), (Some("error"), Some("plan")), "{refused}");
        assert_eq!(refused["value"], "none");

        // While a new plan is computed, the old one is not carried out.
        plan(&mut ws).await;
        ws.send(Message::Text(r#"{"type":"plan","goal_m":[0.1,0.0],"tolerance_m":0.05}"#.into())).await.unwrap();
        ws.send(Message::Text(r#"{"type":"execute","mode":"all"}"#.into())).await.unwrap();
        assert_eq!(answer(&mut ws).await["type"], "ok", "the plan request");
        let first = next(&mut ws, |m| m["type"] == "plan" || m["type"] == "ok" || m["type"] == "error").await;
        if first["type"] != "plan" {
            assert_eq!((first["type"].as_str(), first["field"].as_str()), (Some("error"), Some("plan")), "{first}");
            assert!(first["value"] == "being computed" || first["value"] == "none", "{first}");
            next(&mut ws, |m| m["type"] == "plan").await;
        }
        // The new plan runs, its live interlock passes on the simulated body.
        let mut done = 0;
        for n in 1..=3 {
            assert_eq!(ask(&mut ws, r#"{"type":"execute","mode":"step"}"#).await["type"], "ok");
            let s = settled(&mut ws, Duration::from_secs(30), |s| {
                s["run"]["next_step"] == n || s["run"]["error"].is_string()
            })
            .await;
            assert!(s["run"]["error"].is_null(), "{}", s["run"]);
            done = n;
        }
        assert_eq!(done, 3);
        settled(&mut ws, Duration::from_secs(10), |s| s["holding"] == json!([true, true])).await;
    })
    .await
    .expect("within the limit");
}

#[tokio::test(flavor = "multi_thread", worker_threads = 2)]
async fn a_free_cups_pump_is_switched_on_only_when_it_may_attach() {
    tokio::time::timeout(LIMIT, async {
        let running = start(None).await;
        let (mut ws, _) = connect(running.addr).await;
        held(&mut ws).await;
        assert_eq!(ask(&mut ws, r#"{"type":"take_control"}"#).await["type"], "ok");
        // Bent so that the front cup is not flush: attach_front is refused...
        let s = state(&mut ws).await;
        let (la, lb) = (measured(&s, 0), measured(&s, 1));
        let bend = json!({"type": "set_lengths", "lengths_m": [la + 0.05, lb - 0.03, lb - 0.03]}).to_string();
        assert_eq!(ask(&mut ws, &bend).await["type"], "ok");
        let s = crate::until(&mut ws, Duration::from_secs(15), |s| {
            (measured(s, 0) - la - 0.05).abs() < 1e-3 && (measured(s, 1) - lb + 0.03).abs() < 1e-3
        })
        .await;
        tokio::time::sleep(Duration::from_millis(500)).await;
        let s = {
            let _ = s;
            state(&mut ws).await
        };
        let attach = s["phases"].as_array().unwrap().iter().find(|p| p["phase"] == "attach_front").unwrap().clone();
        assert_eq!(attach["allowed"], false, "{attach}");
        // ... and so is its pump, with the same reason.
        let refused = ask(&mut ws, r#"{"type":"pump","cup":"front","on":true}"#).await;
        assert_eq!((refused["type"].as_str(), refused["field"].as_str()), (Some("error"), Some("on")), "{refused}");
        assert_eq!(refused["message"], attach["reason"], "{refused}");
        let s = state(&mut ws).await;
        assert_eq!(s["telemetry"]["pumps_on"], json!([true, false]));
        // The holding rear cup's pump on again changes nothing and is allowed.
        assert_eq!(ask(&mut ws, r#"{"type":"pump","cup":"rear","on":true}"#).await["type"], "ok");
    })
    .await
    .expect("within the limit");
}
