//! Frames: sizes, round trips, and a decoder that drops bad frames, counts
//! them and carries on.

use leech_protocol::cobs;
use leech_protocol::crc::crc16;
use leech_protocol::frame::{self, Counters, Decoder, EncodeError, FrameError, MAX_ENCODED, MAX_FRAME, MAX_MESSAGE};
use leech_protocol::message::{AckStatus, Command, Report, Seq, Tube};
use leech_protocol::BufferTooSmall;
use proptest::prelude::*;

use crate::decode_all;

fn framed(message: &[u8]) -> Vec<u8> {
    let mut out = [0u8; MAX_FRAME];
    let len = frame::encode(message, &mut out).unwrap();
    out[..len].to_vec()
}

/// A frame of arbitrary payload bytes (a CRC that may or may not match).
fn raw_frame(payload: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; cobs::max_encoded_len(payload.len()) + 1];
    let len = cobs::encode(payload, &mut out).unwrap();
    out[len] = 0;
    out.truncate(len + 1);
    out
}

#[test]
fn sizes() {
    assert_eq!(frame::MAX_PAYLOAD, 64);
    assert_eq!(MAX_MESSAGE, 62);
    assert_eq!(frame::MAX_BODY, 60);
    assert_eq!(MAX_ENCODED, 65);
    assert_eq!(MAX_FRAME, 66);
    assert_eq!(framed(&[0x11; MAX_MESSAGE]).len(), MAX_FRAME);
}

#[test]
fn a_frame_is_the_cobs_payload_and_a_zero() {
    let message = [0x06, 0x07, 0x01, 0x01];
    let crc = crc16(&message).to_le_bytes();
    let payload = [&message[..], &crc].concat();
    assert_eq!(framed(&message), raw_frame(&payload));
}

#[test]
fn the_worked_example_of_the_spec() {
    // docs/protocol.md, "Worked example": Jog L1 by +1000 um, seq 1, and its Ack.
    let jog = crate::command_frame(&Command::Jog { tube: Tube::L1, delta_um: 1000 }, 1);
    assert_eq!(crc16(&[0x05, 0x01, 0x00, 0xE8, 0x03, 0x00, 0x00]), 0x95B0);
    assert_eq!(jog, [0x03, 0x05, 0x01, 0x03, 0xE8, 0x03, 0x01, 0x03, 0xB0, 0x95, 0x00]);
    let ack = crate::report_frame(&Report::Ack { seq: Seq::FIRST, status: AckStatus::Ok });
    assert_eq!(ack, [0x03, 0x80, 0x01, 0x01, 0x03, 0xC8, 0x6E, 0x00]);
}

#[test]
fn encode_refuses_what_is_not_a_message_and_short_buffers() {
    let mut out = [0u8; MAX_FRAME];
    assert_eq!(frame::encode(&[0x02], &mut out), Err(EncodeError::TooShort { len: 1 }));
    assert_eq!(frame::encode(&[0x02; 63], &mut out), Err(EncodeError::TooLong { len: 63 }));
    // [02 01] + CRC: 4 payload bytes, 5 COBS bytes (no zeros), 6 with the delimiter.
    let message = [0x02, 0x01];
    let needed = framed(&message).len();
    let mut short = vec![0u8; needed - 1];
    assert_eq!(
        frame::encode(&message, &mut short),
        Err(EncodeError::BufferTooSmall(BufferTooSmall { needed, available: needed - 1 }))
    );
    let mut tiny = [0u8; 2];
    assert!(matches!(frame::encode(&message, &mut tiny), Err(EncodeError::BufferTooSmall(_))));
    assert_eq!(EncodeError::TooLong { len: 63 }.to_string(), "a 63-byte message exceeds the 62-byte maximum");
}

#[test]
fn decoder_returns_each_message_and_counts_it() {
    let stream = [framed(&[0x02, 1]), framed(&[0x04, 2, 0, 0, 0, 0]), framed(&[0x03, 3])].concat();
    let events = decode_all(&stream);
    assert_eq!(events, [Ok(vec![0x02, 1]), Ok(vec![0x04, 2, 0, 0, 0, 0]), Ok(vec![0x03, 3])]);
}

#[test]
fn empty_frames_are_padding() {
    let stream = [vec![0, 0, 0], framed(&[0x02, 1]), vec![0, 0], framed(&[0x02, 2])].concat();
    let mut decoder = Decoder::new();
    let events: Vec<_> = stream.iter().filter_map(|&b| decoder.push(b).map(|e| e.map(<[u8]>::to_vec))).collect();
    assert_eq!(events, [Ok(vec![0x02, 1]), Ok(vec![0x02, 2])]);
    assert_eq!(decoder.counters(), Counters { frames: 2, bad_crc: 0, bad_frames: 0 });
}

#[test]
fn a_truncated_frame_is_dropped_and_the_next_one_decodes() {
    let good = framed(&[0x05, 9, 0, 0xE8, 3, 0, 0]);
    for cut in 1..good.len() - 1 {
        let stream = [&good[..cut], &[0][..], &good[..]].concat();
        let mut decoder = Decoder::new();
        let events: Vec<_> = stream.iter().filter_map(|&b| decoder.push(b).map(|e| e.map(<[u8]>::to_vec))).collect();
        assert_eq!(events.len(), 2, "cut at {cut}");
        assert!(events[0].is_err(), "cut at {cut}: {:?}", events[0]);
        assert_eq!(events[1], Ok(vec![0x05, 9, 0, 0xE8, 3, 0, 0]));
        let c = decoder.counters();
        assert_eq!((c.frames, c.bad_crc + c.bad_frames), (1, 1));
    }
}

#[test]
fn payloads_shorter_than_a_header_and_crc_are_too_short() {
    for payload in [&[0x11][..], &[0x11, 0x22], &[0x11, 0x22, 0x33]] {
        assert_eq!(decode_all(&raw_frame(payload)), [Err(FrameError::TooShort { len: payload.len() })]);
    }
}

#[test]
fn a_bad_crc_is_reported_with_both_values_and_counted() {
    let mut message = vec![0x04, 1];
    message.extend_from_slice(&[0x10; 12]);
    let crc = crc16(&message);
    let mut payload = [message.clone(), crc.to_le_bytes().to_vec()].concat();
    payload[5] ^= 0x01;
    let computed = crc16(&payload[..payload.len() - 2]);
    let mut decoder = Decoder::new();
    let events: Vec<_> =
        raw_frame(&payload).iter().filter_map(|&b| decoder.push(b).map(|e| e.map(<[u8]>::to_vec))).collect();
    assert_eq!(events, [Err(FrameError::BadCrc { received: crc, computed })]);
    assert_eq!(decoder.counters(), Counters { frames: 0, bad_crc: 1, bad_frames: 0 });
    assert_eq!(
        FrameError::BadCrc { received: 0x1234, computed: 0xABCD }.to_string(),
        "bad CRC: the frame carries 0x1234, its bytes give 0xabcd"
    );
}

#[test]
fn an_oversize_frame_is_reported_once_and_dropped_to_its_delimiter() {
    let mut stream = vec![0x55; 300];
    stream.push(0);
    stream.extend(framed(&[0x03, 7]));
    let mut decoder = Decoder::new();
    let events: Vec<_> = stream.iter().filter_map(|&b| decoder.push(b).map(|e| e.map(<[u8]>::to_vec))).collect();
    assert_eq!(events, [Err(FrameError::Oversize), Ok(vec![0x03, 7])]);
    assert_eq!(decoder.counters(), Counters { frames: 1, bad_crc: 0, bad_frames: 1 });
}

#[test]
fn the_longest_frame_is_not_oversize_and_one_byte_more_is() {
    let longest = framed(&[0x7F; MAX_MESSAGE]);
    assert_eq!(decode_all(&longest), [Ok(vec![0x7F; MAX_MESSAGE])]);
    let mut longer = vec![0x7F; MAX_ENCODED + 1];
    longer.push(0);
    assert_eq!(decode_all(&longer), [Err(FrameError::Oversize)]);
    // 65 non-zero bytes are not oversize (they are a bad frame of another kind).
    let mut at_limit = vec![0x7F; MAX_ENCODED];
    at_limit.push(0);
    assert!(!matches!(decode_all(&at_limit)[..], [Err(FrameError::Oversize)]));
}

#[test]
fn feed_and_push_agree() {
    let stream = [vec![1, 2, 3, 0], framed(&[0x02, 1]), vec![9; 100], vec![0], framed(&[0x03, 2])].concat();
    let mut decoder = Decoder::new();
    let mut rest = &stream[..];
    let mut events = Vec::new();
    while !rest.is_empty() {
        let (event, more) = decoder.feed(rest);
        assert!(more.len() < rest.len());
        events.extend(event.map(|e| e.map(<[u8]>::to_vec)));
        rest = more;
    }
    assert_eq!(events, decode_all(&stream));
    assert_eq!(events.len(), 4);
}

proptest! {
    #[test]
    fn any_message_round_trips(message in proptest::collection::vec(any::<u8>(), 2..=MAX_MESSAGE)) {
        let wire = framed(&message);
        prop_assert!(wire.len() <= MAX_FRAME);
        prop_assert_eq!(wire.iter().position(|&b| b == 0), Some(wire.len() - 1));
        prop_assert_eq!(decode_all(&wire), vec![Ok(message)]);
    }
}
