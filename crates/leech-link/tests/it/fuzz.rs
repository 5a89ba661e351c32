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
