//! The golden frames of the protocol: the simulated device answers each
//! command frame as the spec says (a fresh device: nothing configured).

use leech_link::sim::SimConfig;
use leech_protocol::message::{AckStatus, Refusal, Report, Seq};
use serde_json::Value;

use super::{exchange, fresh_sim};

const GOLDEN: &str = include_str!("../../../leech-protocol/tests/data/golden.json");

fn hex(text: &str) -> Vec<u8> {
    (0..text.len()).step_by(2).map(|i| u8::from_str_radix(&text[i..i + 2], 16).expect("hex")).collect()
}

/// What a fresh device answers to the golden frame `name` carrying `seq`.
fn expected(name: &str, message: &[u8]) -> Option<Report> {
    let seq = Seq::new(message[1]);
    let ack = |status| Some(Report::Ack { seq: seq?, status });
    match name {
        "hello_request" => Some(Report::Hello { reply_to: seq, hello: SimConfig::default().hello }),
        "set_lengths_planar" | "set_lengths_zero" | "set_lengths_negative" | "jog" => {
            ack(AckStatus::Refused(Refusal::NotConfigured))
        }
        "max_payload_unknown_type" => ack(AckStatus::UnknownType),
        // Reports sent to a device: unknown commands, or unanswerable with seq 0.
        _ if message[0] >= 0x80 => seq.and_then(|_| ack(AckStatus::UnknownType)),
        _ => ack(AckStatus::Ok),
    }
}

#[test]
fn the_device_answers_every_golden_frame() {
    let entries: Vec<Value> = serde_json::from_str(GOLDEN).expect("golden.json");
    assert!(entries.len() >= 25);
    for entry in entries {
        let name = entry["name"].as_str().expect("name");
        let payload = hex(entry["payload_hex"].as_str().expect("payload"));
        let message = &payload[..payload.len() - 2];
        let mut sim = fresh_sim(SimConfig::default());
        let answers = exchange(&mut sim, &hex(entry["frame_hex"].as_str().expect("frame")));
        assert_eq!(answers, expected(name, message).into_iter().collect::<Vec<_>>(), "{name}");
    }
}
