//! CRC-16/CCITT-FALSE: the check value and incremental use.

use leech_protocol::crc::{self, crc16};
use proptest::prelude::*;

#[test]
fn check_value_of_the_catalogue() {
    assert_eq!(crc16(b"123456789"), 0x29B1);
    assert_eq!(crc::CHECK, 0x29B1);
}

#[test]
fn the_empty_input_leaves_the_initial_value() {
    assert_eq!(crc16(&[]), 0xFFFF);
}

#[test]
fn a_few_more_values() {
    // From an independent bit-by-bit model of the register (no reflection, no final XOR).
    assert_eq!(crc16(&[0x00]), 0xE1F0);
    assert_eq!(crc16(b"A"), 0xB915);
}

proptest! {
    #[test]
    fn update_continues_a_crc(a in proptest::collection::vec(any::<u8>(), 0..100), b in proptest::collection::vec(any::<u8>(), 0..100)) {
        let whole = [a.clone(), b.clone()].concat();
        prop_assert_eq!(crc::update(crc16(&a), &b), crc16(&whole));
    }

    #[test]
    fn any_single_bit_flip_changes_the_crc(data in proptest::collection::vec(any::<u8>(), 1..62), bit in 0usize..496) {
        let bit = bit % (data.len() * 8);
        let mut flipped = data.clone();
        flipped[bit / 8] ^= 1 << (bit % 8);
        prop_assert_ne!(crc16(&flipped), crc16(&data));
    }
}
