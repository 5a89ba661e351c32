//! CRC-16/CCITT-FALSE, the checksum at the end of every payload.
//!
//! Parameters (in the usual catalogue terms): width 16, polynomial `0x1021`,
//! initial value `0xFFFF`, input and output not reflected, no final XOR.
//! The check value, the CRC of the nine ASCII bytes `"123456789"`, is
//! [`CHECK`] = `0x29B1`.
//!
//! The CRC covers the type byte, the sequence byte and the body; it is sent
//! after them least significant byte first, like every multi-byte field.
//! Bit by bit is fast enough here (at most 62 bytes a frame) and is what a
//! firmware author can check by eye; a table is an optimization either side
//! may make.

/// The CRC of ASCII `"123456789"` under these parameters.
pub const CHECK: u16 = 0x29B1;

/// The CRC register before any byte.
pub const INIT: u16 = 0xFFFF;

/// The generator polynomial, without its `x^16` term.
pub const POLY: u16 = 0x1021;

/// The CRC of `bytes`.
///
/// ```
/// assert_eq!(leech_protocol::crc::crc16(b"123456789"), 0x29B1);
/// ```
pub fn crc16(bytes: &[u8]) -> u16 {
    update(INIT, bytes)
}

/// Continues a CRC over more bytes: `update(crc16(a), b) == crc16(a ++ b)`,
/// for a receiver that checksums bytes as they arrive.
pub fn update(mut crc: u16, bytes: &[u8]) -> u16 {
    for &byte in bytes {
        crc ^= u16::from(byte) << 8;
        for _ in 0..8 {
            crc = if crc & 0x8000 != 0 { (crc << 1) ^ POLY } else { crc << 1 };
        }
    }
    crc
}
