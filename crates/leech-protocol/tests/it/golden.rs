//! Golden frames: `tests/data/golden.json` holds one frame of every message
//! type and the edge cases, as bytes, for this crate and for firmware tests.
//!
//! The cases are defined here; the file is written from them with
//! `LEECH_UPDATE_GOLDEN=1 cargo test -p leech-protocol --test it golden`
//! and otherwise checked against them: every entry re-encoded byte for
//! byte, every frame decoded back to its message.

use leech_protocol::cobs;
use leech_protocol::crc::crc16;
use leech_protocol::frame::MAX_MESSAGE;
use leech_protocol::link::LinkCounters;
use leech_protocol::message::*;
use serde_json::Value;

const PATH: &str = concat!(env!("CARGO_MANIFEST_DIR"), "/tests/data/golden.json");

/// What a case encodes.
pub enum Bytes {
    /// A command with its seq.
    Command(u8, Command),
    /// A report.
    Report(Report),
    /// Message bytes no type gives meaning to (type, seq, body).
    Raw(Vec<u8>),
}

/// One golden frame.
pub struct Case {
    pub name: &'static str,
    pub message: &'static str,
    pub bytes: Bytes,
}

impl Case {
    fn message_bytes(&self) -> Vec<u8> {
        let mut out = [0u8; MAX_MESSAGE];
        let len = match &self.bytes {
            Bytes::Command(seq, c) => c.encode(Seq::new(*seq).unwrap(), &mut out).unwrap(),
            Bytes::Report(r) => r.encode(&mut out).unwrap(),
            Bytes::Raw(raw) => return raw.clone(),
        };
        out[..len].to_vec()
    }

    /// The payload: message bytes and CRC, least significant byte first.
    fn payload(&self) -> Vec<u8> {
        let message = self.message_bytes();
        [message.clone(), crc16(&message).to_le_bytes().to_vec()].concat()
    }

    /// The frame, from the crate's own frame encoder.
    pub fn frame(&self) -> Vec<u8> {
        match &self.bytes {
            Bytes::Command(seq, c) => crate::command_frame(c, *seq),
            Bytes::Report(r) => crate::report_frame(r),
            Bytes::Raw(raw) => {
                let mut out = [0u8; leech_protocol::frame::MAX_FRAME];
                let len = leech_protocol::frame::encode(raw, &mut out).unwrap();
                out[..len].to_vec()
            }
        }
    }
}

fn hello(reply_to: Option<u8>) -> Report {
    Report::Hello {
        reply_to: reply_to.and_then(Seq::new),
        hello: Hello {
            protocol: PROTOCOL_VERSION,
            firmware: FirmwareVersion { major: 0, minor: 3, patch: 1 },
            kind: DeviceKind::MEGA,
            capabilities: Capabilities(0b01),
        },
    }
}

fn ack(seq: u8, status: AckStatus) -> Report {
    Report::Ack { seq: Seq::new(seq).unwrap(), status }
}

/// Every golden case, in file order.
pub fn cases() -> Vec<Case> {
    use Bytes::{Command as C, Raw, Report as R};
    let case = |name, message, bytes| Case { name, message, bytes };
    vec![
        case("hello_request", "Hello request, seq 1", C(1, Command::Hello)),
        case("heartbeat", "Heartbeat, seq 2", C(2, Command::Heartbeat)),
        case("stop", "Stop, seq 3", C(3, Command::Stop)),
        case(
            "set_lengths_planar",
            "SetLengths L1 = 250000 um, L2 = L3 = 200000 um (planar), seq 4",
            C(4, Command::SetLengths { lengths_um: [250_000, 200_000, 200_000] }),
        ),
        case(
            "set_lengths_zero",
            "SetLengths all 0 um, seq 5 (a payload of mostly zeros)",
            C(5, Command::SetLengths { lengths_um: [0; 3] }),
        ),
        case(
            "set_lengths_negative",
            "SetLengths L1 = -1 um, L2 = i32::MIN, L3 = i32::MAX, seq 6",
            C(6, Command::SetLengths { lengths_um: [-1, i32::MIN, i32::MAX] }),
        ),
        case("jog", "Jog L2 by -1500 um, seq 7", C(7, Command::Jog { tube: Tube::L2, delta_um: -1500 })),
        case("pump_front_on", "Pump front on, seq 8", C(8, Command::Pump { cup: Cup::Front, on: true })),
        case("pump_rear_off", "Pump rear off, seq 9", C(9, Command::Pump { cup: Cup::Rear, on: false })),
        case("set_telemetry_100hz", "SetTelemetry every 10 ms, seq 10", C(10, Command::SetTelemetry { period_ms: 10 })),
        case("set_telemetry_off", "SetTelemetry 0 ms (off), seq 11", C(11, Command::SetTelemetry { period_ms: 0 })),
        case(
            "clear_faults",
            "ClearFaults link_lost + motor_stall (0x0003), seq 12",
            C(12, Command::ClearFaults { faults: Faults::LINK_LOST.union(Faults::MOTOR_STALL) }),
        ),
        case(
            "configure_tube",
            "ConfigureTube L1: encoder reversed, 160.000 counts/mm, origin 100000 um, limits 50000..=400000 um, \
             20000 um/s, duty <= 800 permille, kp 1.0, ki 0.05, kd 0.1 (Q16.16: 65536, 3277, 6554), seq 13",
            C(
                13,
                Command::ConfigureTube(TubeConfig {
                    tube: Tube::L1,
                    reverse_motor: false,
                    reverse_encoder: true,
                    counts_per_mm_x1000: 160_000,
                    origin_um: 100_000,
                    min_um: 50_000,
                    max_um: 400_000,
                    max_speed_um_s: 20_000,
                    max_duty_permille: 800,
                    kp_q16: 65_536,
                    ki_q16: 3_277,
                    kd_q16: 6_554,
                }),
            ),
        ),
        case(
            "configure_cups",
            "ConfigureCups attach at 30.0 kPa, detach below 20.0 kPa, 1000 ms without a sensor, seq 14",
            C(14, Command::ConfigureCups(CupConfig::default())),
        ),
        case("heartbeat_seq_255", "Heartbeat, seq 255 (the last before 1)", C(255, Command::Heartbeat)),
        case(
            "heartbeat_crc_with_zero",
            "Heartbeat, seq 193 (CRC 0xB200: a zero byte in the CRC)",
            C(193, Command::Heartbeat),
        ),
        case(
            "stop_payload_ends_in_zero",
            "Stop, seq 64 (CRC 0x0098: the payload's last byte is zero)",
            C(64, Command::Stop),
        ),
        case(
            "device_hello_at_reset",
            "DeviceHello at reset (seq 0): protocol 1.0, firmware 0.3.1, Mega, rear vacuum sensor",
            R(hello(None)),
        ),
        case(
            "device_hello_reply",
            "DeviceHello answering Hello seq 1: protocol 1.0, firmware 0.3.1, Mega, rear vacuum sensor",
            R(hello(Some(1))),
        ),
        case("ack_ok", "Ack seq 4: ok", R(ack(4, AckStatus::Ok))),
        case("ack_refused_last_cup", "Ack seq 9: refused, last cup", R(ack(9, AckStatus::Refused(Refusal::LastCup)))),
        case(
            "ack_refused_not_configured",
            "Ack seq 7: refused, not configured",
            R(ack(7, AckStatus::Refused(Refusal::NotConfigured))),
        ),
        case("ack_unknown_type", "Ack seq 20: unknown type", R(ack(20, AckStatus::UnknownType))),
        case(
            "ack_bad_length",
            "Ack seq 21: bad length, the body must be 12 bytes",
            R(ack(21, AckStatus::BadLength { expected: 12 })),
        ),
        case("ack_bad_value", "Ack seq 22: bad value at body offset 0", R(ack(22, AckStatus::BadValue { offset: 0 }))),
        case(
            "telemetry",
            "Telemetry at 123456 ms: counts 1600/-160/0, lengths 110000/99000/100000 um, duty 250/-250/0 permille, \
             vacuum rear 45.0 kPa, front no sensor, faults none, counters 1000/2/3/4, pumps rear, holding rear, \
             active L1+L2, configured all",
            R(Report::Telemetry(Telemetry {
                time_ms: 123_456,
                counts: [1600, -160, 0],
                lengths_um: [110_000, 99_000, 100_000],
                duty_permille: [250, -250, 0],
                vacuum_kpa_x10: [450, NO_SENSOR],
                faults: Faults::default(),
                counters: LinkCounters { rx_frames: 1000, bad_crc: 2, bad_frames: 3, duplicates: 4 },
                pumps: CupSet(0b01),
                holding: CupSet(0b01),
                active: TubeSet(0b011),
                configured: TubeSet::ALL,
            })),
        ),
        case(
            "telemetry_extremes",
            "Telemetry at u32::MAX ms: counts i32::MIN/i32::MAX/-1, lengths i32::MAX/i32::MIN/0 um, duty \
             -1000/1000/-1 permille, vacuum 0 and 101.3 kPa, every fault bit, counters all 0xFFFF, both pumps, \
             both holding, all tubes active and configured (the longest message, 56-byte payload)",
            R(Report::Telemetry(Telemetry {
                time_ms: u32::MAX,
                counts: [i32::MIN, i32::MAX, -1],
                lengths_um: [i32::MAX, i32::MIN, 0],
                duty_permille: [-1000, 1000, -1],
                vacuum_kpa_x10: [0, 1013],
                faults: Faults(0x003F),
                counters: LinkCounters { rx_frames: 0xFFFF, bad_crc: 0xFFFF, bad_frames: 0xFFFF, duplicates: 0xFFFF },
                pumps: CupSet(0b11),
                holding: CupSet(0b11),
                active: TubeSet::ALL,
                configured: TubeSet::ALL,
            })),
        ),
        case(
            "fault_motor_stall",
            "Fault at 65536 ms: motor_stall (code 1) on tube index 2",
            R(Report::Fault { time_ms: 65_536, code: 1, detail: 2 }),
        ),
        case(
            "fault_link_lost",
            "Fault at 500 ms: link_lost (code 0), detail 0",
            R(Report::Fault { time_ms: 500, code: 0, detail: 0 }),
        ),
        case(
            "max_payload_unknown_type",
            "Type 0x7F (unknown: a device answers Ack unknown type), seq 1, body 0x01..=0x3C: the largest payload, \
             64 bytes, 66 on the wire",
            Raw([vec![0x7F, 0x01], (1..=60).collect()].concat()),
        ),
    ]
}

fn hex(bytes: &[u8]) -> String {
    bytes.iter().map(|b| format!("{b:02x}")).collect()
}

fn unhex(text: &str) -> Vec<u8> {
    assert!(text.len().is_multiple_of(2) && text.bytes().all(|c| c.is_ascii_hexdigit()), "not hex: {text}");
    (0..text.len()).step_by(2).map(|i| u8::from_str_radix(&text[i..i + 2], 16).unwrap()).collect()
}

/// The file's text: a JSON list, one object a case, keys in a fixed order.
fn render(cases: &[Case]) -> String {
    let quote = |s: &str| serde_json::to_string(s).unwrap();
    let entries: Vec<String> = cases
        .iter()
        .map(|c| {
            format!(
                "  {{\n    \"name\": {},\n    \"message\": {},\n    \"payload_hex\": \"{}\",\n    \"frame_hex\": \"{}\"\n  }}",
                quote(c.name),
                quote(c.message),
                hex(&c.payload()),
                hex(&c.frame())
            )
        })
        .collect();
    format!("[\n{}\n]\n", entries.join(",\n"))
}

#[test]
fn golden_frames_match_the_file() {
    let cases = cases();
    if std::env::var_os("LEECH_UPDATE_GOLDEN").is_some() {
        std::fs::write(PATH, render(&cases)).unwrap();
    }
    let text = std::fs::read_to_string(PATH).unwrap();
    let entries = match serde_json::from_str::<Value>(&text).unwrap() {
        Value::Array(entries) => entries,
        other => panic!("golden.json is not a list: {other}"),
    };
    assert_eq!(entries.len(), cases.len(), "entries in golden.json (LEECH_UPDATE_GOLDEN=1 rewrites it)");
    for (entry, case) in entries.iter().zip(&cases) {
        let object = entry.as_object().unwrap();
        let mut keys: Vec<&str> = object.keys().map(String::as_str).collect();
        keys.sort_unstable();
        assert_eq!(keys, ["frame_hex", "message", "name", "payload_hex"]);
        let field = |key: &str| object[key].as_str().unwrap();
        assert_eq!(field("name"), case.name);
        assert_eq!(field("message"), case.message, "{}", case.name);
        let payload = unhex(field("payload_hex"));
        let frame = unhex(field("frame_hex"));
        // Re-encoded, byte for byte.
        assert_eq!(payload, case.payload(), "{}: payload", case.name);
        assert_eq!(frame, case.frame(), "{}: frame", case.name);
        // The frame is the file's payload, COBS-encoded, then 0x00.
        let mut stuffed = vec![0u8; cobs::max_encoded_len(payload.len())];
        let len = cobs::encode(&payload, &mut stuffed).unwrap();
        assert_eq!(frame, [&stuffed[..len], &[0]].concat(), "{}: COBS", case.name);
        // Decoded back.
        let message = &payload[..payload.len() - 2];
        assert_eq!(crate::decode_all(&frame), [Ok(message.to_vec())], "{}: decoding", case.name);
        match &case.bytes {
            Bytes::Command(seq, c) => assert_eq!(Command::decode(message), Ok((Seq::new(*seq).unwrap(), *c))),
            Bytes::Report(r) => assert_eq!(Report::decode(message), Ok(*r)),
            Bytes::Raw(raw) => {
                assert_eq!(Command::decode(message), Err(DecodeError::UnknownType { type_byte: raw[0], seq: raw[1] }))
            }
        }
    }
    assert_eq!(text, render(&cases), "golden.json is not in its canonical form");
}

#[test]
fn golden_cases_cover_every_type_and_the_edges() {
    let cases = cases();
    let mut names: Vec<&str> = cases.iter().map(|c| c.name).collect();
    names.sort_unstable();
    names.dedup();
    assert_eq!(names.len(), cases.len(), "names are unique");
    for t in (0..=255u8).filter(|&t| types::body_len(t).is_some()) {
        assert!(cases.iter().any(|c| c.message_bytes()[0] == t), "no golden frame of type {t:#04x}");
    }
    assert!(cases.iter().any(|c| c.payload().len() == leech_protocol::frame::MAX_PAYLOAD));
    assert!(cases.iter().any(|c| c.payload().ends_with(&[0])));
    assert!(cases.iter().any(|c| c.payload()[c.payload().len() - 2..].contains(&0)));
}
