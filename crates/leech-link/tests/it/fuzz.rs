//! Fuzzing the simulated device with arbitrary, truncated, oversized and
//! replayed frames: it never panics and never gets stuck (a `Hello` after
//! any stream is still answered). 3 x 35 000 cases: over 10^5 in all.

use leech_link::sim::{Sim, SimConfig};
use leech_protocol::message::{Command, Report, Seq};
use proptest::prelude::*;

use super::{exchange, frame, fresh_sim};

const CASES: u32 = 35_000;

/// After anything, a delimiter and a `Hello` get their answer.
fn still_answers(sim: &mut Sim) {
    let mut bytes = vec![0x00];
    bytes.extend(frame(Command::Hello, 77));
    let answers = exchange(sim, &bytes);
    let hello = Report::Hello { reply_to: Seq::new(77), hello: sim.config().hello };
    assert!(answers.contains(&hello), "{answers:?}");
}

/// A valid command frame chosen by `pick`.
fn some_command(pick: u8, value: i32) -> Command {
    match pick % 6 {
        0 => Command::Heartbeat,
        1 => Command::Stop,
        2 => Command::SetLengths { lengths_um: [value; 3] },
        3 => Command::SetTelemetry { period_ms: value as u16 },
        4 => Command::ClearFaults { faults: leech_protocol::message::Faults(value as u16) },
        _ => Command::ConfigureTube(SimConfig::default().tube_config(leech_protocol::message::Tube::L2)),
    }
}

proptest! {
    #![proptest_config(ProptestConfig { cases: CASES, failure_persistence: None, ..ProptestConfig::default() })]

    #[test]
    fn arbitrary_bytes(bytes in proptest::collection::vec(any::<u8>(), 0..200), dt in 0.0..0.02f64) {
        let mut sim = fresh_sim(SimConfig::default());
        exchange(&mut sim, &bytes);
        sim.step(dt);
        still_answers(&mut sim);
    }

    #[test]
    fn truncated_and_oversized_frames(
        pick in any::<u8>(), value in any::<i32>(), seq in 1u8..=255, cut in 0usize..70, pad in 0usize..100, noise in any::<u8>(),
    ) {
        let mut sim = fresh_sim(SimConfig::default());
        let mut bytes = frame(some_command(pick, value), seq);
        // Truncated: its tail lost, delimiter included.
        bytes.truncate(cut.min(bytes.len()));
        // Oversized: non-zero bytes run on past the longest frame.
        bytes.extend(std::iter::repeat_n(noise | 1, pad));
        exchange(&mut sim, &bytes);
        still_answers(&mut sim);
    }

    #[test]
    fn replayed_frames(picks in proptest::collection::vec((any::<u8>(), any::<i32>(), 1u8..=4), 1..8)) {
        let mut sim = fresh_sim(SimConfig::default());
        let mut bytes = Vec::new();
        for (pick, value, seq) in picks {
            // Few distinct seqs: many frames are replays of the last one.
            bytes.extend(frame(some_command(pick, value), seq));
        }
        bytes.extend_from_within(..);
        exchange(&mut sim, &bytes);
        still_answers(&mut sim);
    }
}

/// What the property test feeds the device, one frame (or a pause) at a time.
#[derive(Clone, Debug)]
enum Feed {
    /// A frame with a valid CRC: type byte, seq, body.
    Valid(u8, u8, Vec<u8>),
    /// Again the bytes of an earlier valid frame (its index among them,
    /// modulo their number; the last one when there is none before).
    Replay(usize),
    /// A frame whose CRC does not match.
    BadCrc(u8, u8, Vec<u8>),
    /// A frame whose payload is under 4 bytes (1..=3).
    Short(Vec<u8>),
    /// Time passes, ms.
    Pause(u8),
}

/// A body for `type_byte`: its exact length for a known type (random
/// bytes), or a random length.
fn body() -> impl Strategy<Value = (u8, Vec<u8>)> {
    let kind = prop_oneof![4 => 0x01u8..=0x0A, 1 => 0x0Bu8..=0x7F, 1 => 0x80u8..=0xFF];
    (kind, any::<bool>(), proptest::collection::vec(any::<u8>(), 0..=leech_protocol::frame::MAX_BODY)).prop_map(
        |(kind, exact, mut bytes)| {
            if exact {
                if let Some(len) = leech_protocol::message::types::body_len(kind) {
                    bytes.resize(len, 0x5A);
                }
            }
            (kind, bytes)
        },
    )
}

fn feed() -> impl Strategy<Value = Feed> {
    // Few seqs, so that many frames carry the seq last answered.
    let seq = prop_oneof![1 => Just(0u8), 6 => 1u8..=3, 2 => any::<u8>()];
    prop_oneof![
        10 => (body(), seq.clone()).prop_map(|((kind, body), seq)| Feed::Valid(kind, seq, body)),
        5 => any::<usize>().prop_map(Feed::Replay),
        1 => (body(), seq).prop_map(|((kind, body), seq)| Feed::BadCrc(kind, seq, body)),
        1 => proptest::collection::vec(any::<u8>(), 1..=3).prop_map(Feed::Short),
        1 => (0u8..=3).prop_map(Feed::Pause),
    ]
}

/// The frame of `payload` (COBS, delimiter), with a delimiter first.
fn framed(payload: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; leech_protocol::frame::MAX_FRAME + 1];
    let len = leech_protocol::cobs::encode(payload, &mut out[1..]).expect("fits");
    out.truncate(len + 1);
    out.push(0);
    out
}

/// Feeds `bytes` and returns every report the device sent, each checked to
/// be a well-formed frame of a known report.
fn answers(sim: &mut Sim, bytes: &[u8], dt_s: f64) -> Vec<Report> {
    sim.receive(bytes);
    sim.step(dt_s);
    let mut out = Vec::new();
    sim.take_output(&mut out);
    let mut decoder = leech_protocol::frame::Decoder::new();
    let mut reports = Vec::new();
    for byte in out {
        match decoder.push(byte) {
            Some(Ok(message)) => reports.push(Report::decode(message).expect("a well-formed report")),
            Some(Err(e)) => panic!("a malformed frame from the device: {e:?}"),
            None => {}
        }
    }
    reports
}

/// What a command's effect shows in the state (not the counters, not time).
fn effects(sim: &Sim) -> impl PartialEq + std::fmt::Debug {
    let s = sim.state();
    (s.targets_um, s.configured, s.pumps, s.faults, s.telemetry_period_ms)
}

proptest! {
    // 1500 cases of 50..150 feeds, 5 in 6 of them frames: over 10^5 frames
    // (under a second in release).
    #![proptest_config(ProptestConfig { cases: 1500, failure_persistence: None, ..ProptestConfig::default() })]

    /// Valid-CRC frames of every type, random and exact bodies, replays,
    /// bad CRCs and short payloads, with time passing now and then: no
    /// panic; every answer well-formed and to the frame's seq; a retry
    /// (the seq last answered) never executed again and answered as before;
    /// a Hello always answered; the counters as section 10 defines them.
    #[test]
    fn valid_frames_and_replays(feeds in proptest::collection::vec(feed(), 50..150)) {
        let mut sim = fresh_sim(SimConfig::default());
        let mut sent: Vec<Vec<u8>> = Vec::new();
        // The last answered command's seq and answer (the device's memory).
        let mut last: Option<(u8, Report)> = None;
        let (mut valid, mut bad_crc, mut short, mut dropped, mut duplicates) = (0u32, 0u32, 0u32, 0u32, 0u32);
        let mut elapsed_ms = 0u32;
        for feed in feeds {
            let message = match feed {
                Feed::Valid(kind, seq, body) => {
                    let mut message = vec![kind, seq];
                    message.extend(body);
                    message
                }
                Feed::Replay(i) if !sent.is_empty() => sent[i % sent.len()].clone(),
                Feed::Replay(_) => continue,
                Feed::BadCrc(kind, seq, body) => {
                    let mut payload = vec![kind, seq];
                    payload.extend(body);
                    let crc = leech_protocol::crc::crc16(&payload);
                    payload.extend((crc ^ 0x0101).to_le_bytes());
                    answers(&mut sim, &framed(&payload), 0.0);
                    bad_crc += 1;
                    continue;
                }
                Feed::Short(payload) => {
                    answers(&mut sim, &framed(&payload), 0.0);
                    short += 1;
                    continue;
                }
                Feed::Pause(ms) => {
                    // Well within the 500 ms link timeout in all: the
                    // device never forgets its last answer on its own.
                    if elapsed_ms + u32::from(ms) < 400 {
                        elapsed_ms += u32::from(ms);
                        answers(&mut sim, &[], f64::from(ms) / 1e3);
                    }
                    continue;
                }
            };
            sent.push(message.clone());
            let mut wire = vec![0u8];
            let mut frame = [0u8; leech_protocol::frame::MAX_FRAME];
            let len = leech_protocol::frame::encode(&message, &mut frame).expect("fits");
            wire.extend_from_slice(&frame[..len]);
            valid += 1;
            let (kind, seq) = (message[0], message[1]);
            let before = effects(&sim);
            let got = answers(&mut sim, &wire, 0.0);
            let replies: Vec<&Report> = got
                .iter()
                .filter(|r| matches!(r, Report::Ack { .. } | Report::Hello { reply_to: Some(_), .. }))
                .collect();
            if seq == 0 || kind >= 0x80 {
                // Unanswerable, or a report type (an echo): dropped and
                // counted (sections 4.6, 10), never answered.
                dropped += 1;
                prop_assert!(replies.is_empty(), "{message:?}: {got:?}");
                prop_assert_eq!(effects(&sim), before);
                continue;
            }
            prop_assert_eq!(replies.len(), 1, "one answer to {:?}: {:?}", message, got);
            let reply = *replies[0];
            let hello = kind == leech_protocol::message::types::HELLO && message.len() == 2;
            if hello {
                let expected = Report::Hello { reply_to: Seq::new(seq), hello: sim.config().hello };
                prop_assert_eq!(&reply, &expected);
                last = None;
                continue;
            }
            prop_assert!(matches!(reply, Report::Ack { seq: s, .. } if s.get() == seq), "{reply:?}");
            match &last {
                Some((last_seq, answer)) if *last_seq == seq => {
                    // A retry: answered from memory, not carried out again.
                    duplicates += 1;
                    prop_assert_eq!(&reply, answer);
                    prop_assert_eq!(effects(&sim), before, "{:?} ran twice", message);
                }
                _ => last = Some((seq, reply)),
            }
        }
        let counters = sim.state().counters;
        prop_assert_eq!(counters.rx_frames, valid);
        prop_assert_eq!(counters.bad_crc, bad_crc);
        // Section 10: a command with seq 0, or a report type, is counted as
        // received (its CRC matched) and as dropped.
        prop_assert_eq!(counters.bad_frames, short + dropped);
        prop_assert_eq!(counters.rx_frames + counters.bad_crc + counters.bad_frames - dropped, valid + bad_crc + short);
        prop_assert_eq!(counters.duplicates, duplicates);
        still_answers(&mut sim);
    }
}
