// Framing of the LEeCH protocol (docs/protocol.md, section 3), in fixed memory.
//
// Rules (sizes in bytes):
// * message = type (1), seq (1), body: 2..=62;
// * payload = message, then CRC-16/CCITT-FALSE of the message, low byte first: 4..=64;
//   CRC: polynomial 0x1021, initial 0xFFFF, not reflected, no final XOR ("123456789" -> 0x29B1);
// * frame = COBS(payload), then one 0x00: at most 66 on the wire. Payloads of at most 64
//   bytes never fill a COBS block, so a frame is always payload + 2 bytes.
// * Receiving (3.4): bytes other than 0x00 go into a 65-byte buffer; a 66th byte without a
//   delimiter makes the frame oversize (one bad frame; bytes are dropped up to the next 0x00).
//   A 0x00 after an empty buffer is padding (not counted). Otherwise the buffer is decoded:
//   malformed COBS or a payload under 4 bytes is a bad frame, a CRC mismatch a bad CRC, a
//   match a received frame whose message is handed on.
#pragma once

#include <stdint.h>

const uint8_t MAX_PAYLOAD = 64;
const uint8_t MAX_ENCODED = MAX_PAYLOAD + 1;
const uint8_t MAX_FRAME = MAX_ENCODED + 1;

uint16_t crc16(const uint8_t *p, uint8_t n);

// Frames the n-byte message into out (MAX_FRAME bytes suffice); returns the frame's length,
// delimiter included.
uint8_t frame_encode(const uint8_t *message, uint8_t n, uint8_t *out);

// The receiver of section 3.4, with the counters of section 10 that it owns (each wraps at
// 65535; bad_frames also gets the device's dropped seq-0 commands).
struct Receiver {
    uint8_t encoded[MAX_ENCODED];
    uint8_t len;
    bool discarding;
    uint8_t message[MAX_PAYLOAD];
    uint16_t rx_frames;
    uint16_t bad_crc;
    uint16_t bad_frames;

    // Takes one byte from the line; returns the length of the message now in `message`
    // when the byte completes a frame whose CRC matches, else 0.
    uint8_t push(uint8_t byte);
};
