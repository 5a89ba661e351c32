//! Consistent Overhead Byte Stuffing: bytes without any zero, so that a
//! single `0x00` can end every frame on the wire.
//!
//! Rules:
//!
//! * The encoded form is a run of blocks. Each block starts with a code byte
//!   `c` (1..=255) followed by `c - 1` data bytes, none of them zero.
//! * A block with `c < 255` stands for its data bytes followed by one zero,
//!   except the last block of the input, whose zero is not part of the data.
//!   A block with `c = 255` stands for its 254 data bytes alone.
//! * Encoding `n` bytes yields at most `n + n / 254 + 1` bytes
//!   ([`max_encoded_len`]); the empty input encodes to `[0x01]`.
//! * A full block at the very end of the input is not followed by an empty
//!   `0x01` block (the canonical encoding; the decoder accepts both).
//!
//! These functions work on whole slices and never panic: a short output
//! buffer or a malformed input is an error.

use core::fmt;

use crate::BufferTooSmall;

/// The most bytes [`encode`] can produce for `len` input bytes: one code
/// byte per started block of 254 data bytes.
pub const fn max_encoded_len(len: usize) -> usize {
    len + len / 254 + 1
}

/// Encodes `input` into `out`, returning the number of bytes written (no
/// zero among them; the caller appends the `0x00` delimiter).
pub fn encode(input: &[u8], out: &mut [u8]) -> Result<usize, BufferTooSmall> {
    // The exact length is known before writing, so a short buffer is refused
    // up front instead of leaving a half-written frame behind.
    let needed = blocks(input, |_, _| {});
    if out.len() < needed {
        return Err(BufferTooSmall { needed, available: out.len() });
    }
    Ok(blocks(input, |index, byte| {
        if let Some(slot) = out.get_mut(index) {
            *slot = byte;
        }
    }))
}

/// Walks `input`'s canonical encoding, handing each output byte with its
/// index to `emit`; returns the encoded length. A code byte is emitted once
/// its block is closed, so indexes do not arrive in order.
fn blocks(input: &[u8], mut emit: impl FnMut(usize, u8)) -> usize {
    let mut code_at = 0;
    let mut next = 1;
    let mut code: u8 = 1;
    for (i, &byte) in input.iter().enumerate() {
        if byte != 0 {
            emit(next, byte);
            next += 1;
            code += 1;
        }
        // A zero ends the block; so does a full one, unless it ends the input.
        if byte == 0 || (code == 0xFF && i + 1 < input.len()) {
            emit(code_at, code);
            code_at = next;
            next += 1;
            code = 1;
        }
    }
    emit(code_at, code);
    next
}

/// Decodes `input` (without its `0x00` delimiter) into `out`, returning the
/// number of bytes written.
pub fn decode(input: &[u8], out: &mut [u8]) -> Result<usize, DecodeError> {
    let mut read = 0;
    let mut written = 0;
    let capacity = out.len();
    let mut put = |byte: u8, written: &mut usize| match out.get_mut(*written) {
        Some(slot) => {
            *slot = byte;
            *written += 1;
            Ok(())
        }
        None => Err(DecodeError::OutputFull { capacity }),
    };
    while let Some(&code) = input.get(read) {
        if code == 0 {
            return Err(DecodeError::Zero { index: read });
        }
        read += 1;
        for _ in 1..code {
            match input.get(read) {
                None => return Err(DecodeError::Truncated { code, index: read }),
                Some(0) => return Err(DecodeError::Zero { index: read }),
                Some(&byte) => put(byte, &mut written)?,
            }
            read += 1;
        }
        // A short block's zero belongs to the data unless the block ends the input.
        if code != 0xFF && read < input.len() {
            put(0, &mut written)?;
        }
    }
    Ok(written)
}

/// What was wrong with COBS-encoded bytes.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum DecodeError {
    /// A zero byte inside the encoded bytes (zeros only delimit frames).
    Zero {
        /// Its index in the input.
        index: usize,
    },
    /// A block's code promised more data bytes than the input holds.
    Truncated {
        /// The block's code byte.
        code: u8,
        /// The index where the input ended.
        index: usize,
    },
    /// The decoded bytes do not fit in the output buffer.
    OutputFull {
        /// The output buffer's length.
        capacity: usize,
    },
}

impl fmt::Display for DecodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            DecodeError::Zero { index } => write!(f, "COBS: a zero byte at index {index} inside a frame"),
            DecodeError::Truncated { code, index } => {
                write!(f, "COBS: block code {code:#04x} runs past the end of the frame at index {index}")
            }
            DecodeError::OutputFull { capacity } => {
                write!(f, "COBS: the decoded bytes exceed the {capacity}-byte output buffer")
            }
        }
    }
}

impl core::error::Error for DecodeError {}
