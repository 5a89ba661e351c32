//! Frames: message bytes to wire bytes and back, with the CRC and the
//! delimiter.
//!
//! Rules (sizes in bytes):
//!
//! * A **message** is `type` (1), `seq` (1) and a body: 2 to
//!   [`MAX_MESSAGE`] = 62 bytes. The [`message`](crate::message) module gives
//!   it meaning; this module only carries it.
//! * The **payload** is the message followed by its CRC-16/CCITT-FALSE
//!   ([`crc`]), least significant byte first: 4 to
//!   [`MAX_PAYLOAD`] = 64 bytes.
//! * The **frame** is the payload COBS-encoded ([`cobs`]), then
//!   one `0x00`: at most [`MAX_ENCODED`] = 65 bytes before the delimiter and
//!   [`MAX_FRAME`] = 66 on the wire.
//! * A receiver collects bytes up to each `0x00`. An empty frame (two zeros
//!   in a row, or a zero at the start) is padding and is ignored: a sender
//!   may put a `0x00` before a frame to end whatever partial frame the other
//!   side holds. More than 65 bytes without a zero is an oversize frame: it
//!   is reported once and its bytes are dropped up to the next zero, where
//!   reception starts afresh. Every other bad frame (COBS, length, CRC) is
//!   also dropped whole; the next frame after its zero is unaffected.
//!
//! [`Decoder`] does this one byte or one slice at a time, in fixed memory,
//! and counts what it received ([`Counters`]).

use core::fmt;

use crate::{cobs, crc, BufferTooSmall};

/// Type and sequence bytes at the start of every message.
pub const HEADER_LEN: usize = 2;
/// The CRC after the message.
pub const CRC_LEN: usize = 2;
/// The largest payload (message and CRC).
pub const MAX_PAYLOAD: usize = 64;
/// The largest message (type, seq, body).
pub const MAX_MESSAGE: usize = MAX_PAYLOAD - CRC_LEN;
/// The largest body.
pub const MAX_BODY: usize = MAX_MESSAGE - HEADER_LEN;
/// The smallest payload: a header and a CRC, no body.
pub const MIN_PAYLOAD: usize = HEADER_LEN + CRC_LEN;
/// The most COBS bytes of a frame, without the delimiter.
pub const MAX_ENCODED: usize = cobs::max_encoded_len(MAX_PAYLOAD);
/// The most bytes a frame takes on the wire, with the delimiter.
pub const MAX_FRAME: usize = MAX_ENCODED + 1;
/// The byte that ends every frame.
pub const DELIMITER: u8 = 0x00;

/// Frames `message` (type, seq, body) into `out`: CRC appended, COBS
/// encoded, `0x00` appended. Returns the number of bytes written; an `out`
/// of [`MAX_FRAME`] bytes always suffices.
pub fn encode(message: &[u8], out: &mut [u8]) -> Result<usize, EncodeError> {
    if message.len() < HEADER_LEN {
        return Err(EncodeError::TooShort { len: message.len() });
    }
    if message.len() > MAX_MESSAGE {
        return Err(EncodeError::TooLong { len: message.len() });
    }
    let mut payload = [0u8; MAX_PAYLOAD];
    let len = message.len() + CRC_LEN;
    let (body, tail) = payload.split_at_mut(message.len());
    body.copy_from_slice(message);
    for (slot, byte) in tail.iter_mut().zip(crc::crc16(message).to_le_bytes()) {
        *slot = byte;
    }
    let payload = payload.get(..len).unwrap_or_default();
    // The delimiter needs one byte more than the COBS bytes.
    let available = out.len();
    let too_small = |needed| EncodeError::BufferTooSmall(BufferTooSmall { needed, available });
    let encoded = cobs::encode(payload, out).map_err(|e| too_small(e.needed + 1))?;
    let Some(slot) = out.get_mut(encoded) else {
        return Err(too_small(encoded + 1));
    };
    *slot = DELIMITER;
    Ok(encoded + 1)
}

/// Why a message could not be framed.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum EncodeError {
    /// Fewer than the 2 header bytes.
    TooShort {
        /// The message's length in bytes.
        len: usize,
    },
    /// More than [`MAX_MESSAGE`] bytes.
    TooLong {
        /// The message's length in bytes.
        len: usize,
    },
    /// The output buffer cannot hold the frame.
    BufferTooSmall(BufferTooSmall),
}

impl fmt::Display for EncodeError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            EncodeError::TooShort { len } => {
                write!(f, "a {len}-byte message has no room for its type and sequence bytes (2 bytes)")
            }
            EncodeError::TooLong { len } => write!(f, "a {len}-byte message exceeds the {MAX_MESSAGE}-byte maximum"),
            EncodeError::BufferTooSmall(e) => write!(f, "frame: {e}"),
        }
    }
}

impl core::error::Error for EncodeError {}

/// Why a received frame was dropped.
#[derive(Clone, Copy, Debug, PartialEq, Eq, Hash)]
pub enum FrameError {
    /// More than [`MAX_ENCODED`] bytes arrived without a delimiter.
    Oversize,
    /// The bytes are not valid COBS.
    Cobs(cobs::DecodeError),
    /// The payload is shorter than a header and a CRC.
    TooShort {
        /// The decoded payload's length in bytes.
        len: usize,
    },
    /// The CRC sent does not match the CRC of the bytes received.
    BadCrc {
        /// The CRC in the frame.
        received: u16,
        /// The CRC of the message bytes as received.
        computed: u16,
    },
}

impl fmt::Display for FrameError {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            FrameError::Oversize => {
                write!(f, "oversize frame: more than {MAX_ENCODED} bytes without a 0x00 delimiter")
            }
            FrameError::Cobs(e) => write!(f, "bad frame: {e}"),
            FrameError::TooShort { len } => {
                write!(f, "bad frame: a {len}-byte payload is shorter than the {MIN_PAYLOAD}-byte minimum")
            }
            FrameError::BadCrc { received, computed } => {
                write!(f, "bad CRC: the frame carries {received:#06x}, its bytes give {computed:#06x}")
            }
        }
    }
}

impl core::error::Error for FrameError {}

/// What a [`Decoder`] received since it was made; each count wraps at
/// `u32::MAX`.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Hash)]
pub struct Counters {
    /// Frames whose CRC matched (handed on as messages).
    pub frames: u32,
    /// Frames dropped for a CRC mismatch.
    pub bad_crc: u32,
    /// Frames dropped for anything else: oversize, bad COBS, too short.
    pub bad_frames: u32,
}

/// A streaming frame receiver in fixed memory (about 130 bytes).
///
/// Feed it bytes as they arrive, one at a time ([`push`](Decoder::push)) or
/// a slice at a time ([`feed`](Decoder::feed)); each delimiter yields the
/// message bytes of a good frame or the reason a bad one was dropped.
#[derive(Clone, Debug)]
pub struct Decoder {
    /// COBS bytes of the frame being received.
    encoded: [u8; MAX_ENCODED],
    len: usize,
    /// The frame in progress overflowed: drop bytes up to the next delimiter.
    discarding: bool,
    /// The last decoded payload.
    payload: [u8; MAX_PAYLOAD],
    counters: Counters,
}

impl Default for Decoder {
    fn default() -> Self {
        Decoder::new()
    }
}

impl Decoder {
    /// A decoder waiting for the first frame.
    pub const fn new() -> Decoder {
        Decoder {
            encoded: [0; MAX_ENCODED],
            len: 0,
            discarding: false,
            payload: [0; MAX_PAYLOAD],
            counters: Counters { frames: 0, bad_crc: 0, bad_frames: 0 },
        }
    }

    /// Takes one byte. At a delimiter that ends a non-empty frame, returns
    /// its message bytes (type, seq, body; CRC checked and removed) or why
    /// it was dropped; an oversize frame is reported at the byte that
    /// overflows. Otherwise `None`.
    pub fn push(&mut self, byte: u8) -> Option<Result<&[u8], FrameError>> {
        let event = self.step(byte)?;
        Some(event.map(|len| self.payload.get(..len).unwrap_or_default()))
    }

    /// Takes bytes up to and including the first that completes a frame
    /// (or overflows one). Returns that event, if any, and the bytes not yet
    /// taken; call again with them until they are empty.
    ///
    /// ```
    /// use leech_protocol::frame::{self, Decoder};
    ///
    /// let mut wire = [0u8; 2 * frame::MAX_FRAME];
    /// let a = frame::encode(&[0x02, 1], &mut wire).unwrap();
    /// let b = frame::encode(&[0x02, 2], &mut wire[a..]).unwrap();
    ///
    /// let mut decoder = Decoder::new();
    /// let mut rest = &wire[..a + b];
    /// let mut seqs = Vec::new();
    /// while !rest.is_empty() {
    ///     let (event, more) = decoder.feed(rest);
    ///     if let Some(Ok(message)) = event {
    ///         seqs.push(message[1]);
    ///     }
    ///     rest = more;
    /// }
    /// assert_eq!(seqs, [1, 2]);
    /// ```
    pub fn feed<'b>(&mut self, bytes: &'b [u8]) -> (Option<Result<&[u8], FrameError>>, &'b [u8]) {
        for (i, &byte) in bytes.iter().enumerate() {
            if let Some(event) = self.step(byte) {
                let rest = bytes.get(i + 1..).unwrap_or_default();
                return (Some(event.map(|len| self.payload.get(..len).unwrap_or_default())), rest);
            }
        }
        (None, &[])
    }

    /// What this decoder has received so far.
    pub fn counters(&self) -> Counters {
        self.counters
    }

    /// One byte; a good frame is returned as its message length in
    /// `payload` (a length, not a borrow, so that `feed` can loop).
    fn step(&mut self, byte: u8) -> Option<Result<usize, FrameError>> {
        if byte != DELIMITER {
            if self.discarding {
                return None;
            }
            match self.encoded.get_mut(self.len) {
                Some(slot) => {
                    *slot = byte;
                    self.len += 1;
                    return None;
                }
                None => {
                    self.discarding = true;
                    self.len = 0;
                    return Some(Err(self.count(FrameError::Oversize)));
                }
            }
        }
        let len = core::mem::take(&mut self.len);
        if core::mem::take(&mut self.discarding) || len == 0 {
            // The end of an oversize frame (already reported), or padding.
            return None;
        }
        let encoded = self.encoded.get(..len).unwrap_or_default();
        Some(match check(encoded, &mut self.payload) {
            Ok(message_len) => {
                self.counters.frames = self.counters.frames.wrapping_add(1);
                Ok(message_len)
            }
            Err(e) => Err(self.count(e)),
        })
    }

    fn count(&mut self, error: FrameError) -> FrameError {
        let counter = match error {
            FrameError::BadCrc { .. } => &mut self.counters.bad_crc,
            _ => &mut self.counters.bad_frames,
        };
        *counter = counter.wrapping_add(1);
        error
    }
}

/// Decodes one frame's COBS bytes into `payload` and checks its length and
/// CRC; returns the message's length.
fn check(encoded: &[u8], payload: &mut [u8; MAX_PAYLOAD]) -> Result<usize, FrameError> {
    let len = cobs::decode(encoded, payload).map_err(FrameError::Cobs)?;
    let Some((message, [lo, hi])) = payload.get(..len).and_then(|p| p.split_last_chunk::<CRC_LEN>()) else {
        return Err(FrameError::TooShort { len });
    };
    if message.len() < HEADER_LEN {
        return Err(FrameError::TooShort { len });
    }
    let received = u16::from_le_bytes([*lo, *hi]);
    let computed = crc::crc16(message);
    if received != computed {
        return Err(FrameError::BadCrc { received, computed });
    }
    Ok(message.len())
}
