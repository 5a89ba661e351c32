//! COBS: known encodings, round trips, malformed input.

use leech_protocol::cobs::{self, DecodeError};
use leech_protocol::BufferTooSmall;
use proptest::prelude::*;

fn encode(input: &[u8]) -> Vec<u8> {
    let mut out = vec![0u8; cobs::max_encoded_len(input.len())];
    let len = cobs::encode(input, &mut out).unwrap();
    out.truncate(len);
    out
}

fn decode(input: &[u8]) -> Result<Vec<u8>, DecodeError> {
    let mut out = vec![0u8; input.len()];
    cobs::decode(input, &mut out).map(|len| out[..len].to_vec())
}

#[test]
fn known_vectors() {
    let nonzero = |n: usize| (0..n).map(|i| (i % 255 + 1) as u8).collect::<Vec<u8>>();
    let cases: Vec<(Vec<u8>, Vec<u8>)> = vec![
        (vec![], vec![0x01]),
        (vec![0x00], vec![0x01, 0x01]),
        (vec![0x00, 0x00], vec![0x01, 0x01, 0x01]),
        (vec![0x42], vec![0x02, 0x42]),
        (vec![0x11, 0x22, 0x00, 0x33], vec![0x03, 0x11, 0x22, 0x02, 0x33]),
        (vec![0x11, 0x22, 0x33, 0x44], vec![0x05, 0x11, 0x22, 0x33, 0x44]),
        (vec![0x11, 0x00, 0x00, 0x00], vec![0x02, 0x11, 0x01, 0x01, 0x01]),
        (vec![0x00, 0x7E, 0x00], vec![0x01, 0x02, 0x7E, 0x01]),
        // A full block at the end is not followed by an empty one.
        (nonzero(254), [vec![0xFF], nonzero(254)].concat()),
        // One byte more opens a second block.
        (nonzero(255), [vec![0xFF], nonzero(254), vec![0x02, 0xFF]].concat()),
        // A zero before the run: one empty block, then a full one.
        ([vec![0x00], nonzero(254)].concat(), [vec![0x01, 0xFF], nonzero(254)].concat()),
        // A zero after a full block: the block carries no zero, so an empty one follows.
        ([nonzero(254), vec![0x00]].concat(), [vec![0xFF], nonzero(254), vec![0x01, 0x01]].concat()),
    ];
    for (raw, encoded) in cases {
        assert_eq!(encode(&raw), encoded, "encoding {raw:02x?}");
        assert_eq!(decode(&encoded).unwrap(), raw, "decoding {encoded:02x?}");
    }
}

#[test]
fn a_trailing_empty_block_after_a_full_one_also_decodes() {
    let data: Vec<u8> = (1..=254).collect();
    let long_form = [vec![0xFF], data.clone(), vec![0x01]].concat();
    assert_eq!(decode(&long_form).unwrap(), data);
}

#[test]
fn malformed_input_is_an_error_naming_where() {
    assert_eq!(decode(&[0x03, 0x11, 0x00, 0x22]), Err(DecodeError::Zero { index: 2 }));
    assert_eq!(decode(&[0x00]), Err(DecodeError::Zero { index: 0 }));
    assert_eq!(decode(&[0x05, 0x11, 0x22]), Err(DecodeError::Truncated { code: 0x05, index: 3 }));
    let mut small = [0u8; 2];
    assert_eq!(cobs::decode(&[0x04, 1, 2, 3], &mut small), Err(DecodeError::OutputFull { capacity: 2 }));
    assert_eq!(
        DecodeError::Truncated { code: 5, index: 3 }.to_string(),
        "COBS: block code 0x05 runs past the end of the frame at index 3"
    );
}

#[test]
fn a_short_output_buffer_is_refused_before_writing() {
    let mut out = [0xAAu8; 3];
    assert_eq!(cobs::encode(&[1, 2, 3], &mut out), Err(BufferTooSmall { needed: 4, available: 3 }));
    assert_eq!(out, [0xAA; 3]);
}

proptest! {
    #[test]
    fn round_trip_without_zeros_within_the_bound(data in proptest::collection::vec(any::<u8>(), 0..700)) {
        let encoded = encode(&data);
        prop_assert!(!encoded.contains(&0));
        prop_assert!(encoded.len() <= cobs::max_encoded_len(data.len()));
        prop_assert!(encoded.len() > data.len());
        prop_assert_eq!(decode(&encoded).unwrap(), data);
    }

    #[test]
    fn zero_heavy_data_round_trips(data in proptest::collection::vec(prop_oneof![Just(0u8), any::<u8>()], 0..300)) {
        prop_assert_eq!(decode(&encode(&data)).unwrap(), data);
    }

    #[test]
    fn any_bytes_decode_without_panic(data in proptest::collection::vec(any::<u8>(), 0..300), cap in 0usize..300) {
        let mut out = vec![0u8; cap];
        let _ = cobs::decode(&data, &mut out);
    }
}
