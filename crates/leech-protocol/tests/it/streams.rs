//! Random byte streams: 10^5 of them through the decoder and the message
//! decoders, without a panic, and never leaving the decoder stuck: a valid
//! frame after the garbage still comes out.

use std::sync::OnceLock;

use leech_protocol::frame::{Decoder, FrameError};
use leech_protocol::message::{Command, Report};
use proptest::prelude::*;
use proptest::sample::Index;

/// Garbage of three kinds: any bytes; bytes with many zeros (frames of
/// every length); long runs without a zero (oversize frames). Drawn as
/// 64-bit words and cut to bytes: element by element, proptest takes ten
/// times longer to draw them.
fn garbage() -> impl Strategy<Value = Vec<u8>> {
    (0u8..3, proptest::collection::vec(any::<u64>(), 0..25), 0usize..8).prop_map(|(kind, words, cut)| {
        let mut bytes: Vec<u8> = words.iter().flat_map(|w| w.to_le_bytes()).collect();
        bytes.truncate(bytes.len().saturating_sub(cut));
        for b in &mut bytes {
            *b = match kind {
                0 => *b,
                1 if *b < 32 => 0,
                1 => *b,
                _ => *b | 1,
            };
        }
        bytes
    })
}

/// Valid frames and the message bytes each carries: the golden cases, one
/// of every message type and the edge cases.
fn frames() -> &'static [(Vec<u8>, Vec<u8>)] {
    static FRAMES: OnceLock<Vec<(Vec<u8>, Vec<u8>)>> = OnceLock::new();
    FRAMES.get_or_init(|| {
        crate::golden::cases()
            .iter()
            .map(|case| {
                let wire = case.frame();
                let message = crate::decode_all(&wire).pop().unwrap().unwrap();
                (wire, message)
            })
            .collect()
    })
}

/// Feeds `bytes` in chunks of the given sizes (cycled); every message is
/// run through both message decoders.
fn feed_in_chunks(decoder: &mut Decoder, bytes: &[u8], chunks: &[usize]) -> Vec<Result<Vec<u8>, FrameError>> {
    let mut events = vec![];
    let mut rest = bytes;
    let mut sizes = chunks.iter().cycle();
    while !rest.is_empty() {
        let take = (*sizes.next().unwrap()).clamp(1, rest.len());
        let (mut chunk, tail) = rest.split_at(take);
        while !chunk.is_empty() {
            let (event, more) = decoder.feed(chunk);
            if let Some(event) = event {
                if let Ok(message) = event {
                    let _ = Command::decode(message);
                    let _ = Report::decode(message);
                }
                events.push(event.map(<[u8]>::to_vec));
            }
            chunk = more;
        }
        rest = tail;
    }
    events
}

proptest! {
    #![proptest_config(ProptestConfig::with_cases(100_000))]

    #[test]
    fn garbage_never_panics_nor_sticks(
        garbage in garbage(),
        first in any::<Index>(),
        second in any::<Index>(),
        chunks in proptest::collection::vec(1usize..40, 1..4),
    ) {
        let _ = Command::decode(&garbage);
        let _ = Report::decode(&garbage);
        let (first, first_message) = first.get(frames());
        let (second, second_message) = second.get(frames());
        let mut decoder = Decoder::new();
        let stream = [&garbage[..], first, second].concat();
        let events = feed_in_chunks(&mut decoder, &stream, &chunks);
        // The frame after a delimiter always decodes, whatever came before.
        prop_assert_eq!(events.last(), Some(&Ok(second_message.clone())));
        if garbage.is_empty() || garbage.ends_with(&[0]) {
            prop_assert_eq!(&events[events.len() - 2], &Ok(first_message.clone()));
        }
        // Every event is counted once.
        let c = decoder.counters();
        prop_assert_eq!((c.frames + c.bad_crc + c.bad_frames) as usize, events.len());
        prop_assert_eq!(c.frames as usize, events.iter().filter(|e| e.is_ok()).count());
    }
}
