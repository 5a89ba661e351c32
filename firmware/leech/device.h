// The device side of the LEeCH protocol 1.0 (docs/protocol.md): commands, acknowledgements and
// duplicates, the last-cup rule and holding, link loss, fault detection, telemetry. Pure logic:
// leech.ino feeds it frames, encoder counts, vacuum readings and the millisecond clock, and
// drives the motors and pumps from what it decides.
//
// Times are millis() (ms, u32, compared by wrapping differences). Rules, besides control.h's:
// * A frame from a host (CRC matched, type below 0x80, seq not 0) arms or restarts the link
//   timer; 500 ms without one stops the motors (pumps kept), latches LINK_LOST, forgets the
//   remembered seq and disarms the timer until the next frame from a host.
// * A command with seq 0 is dropped and counted as a bad frame; Hello forgets the remembered
//   seq and is answered by DeviceHello; a command with the remembered seq gets the remembered
//   Ack again (a duplicate, not executed); any other is decoded (UnknownType, BadLength,
//   BadValue), executed, and its Ack remembered.
// * A cup holds when its pump is on and, with a sensor, its vacuum reached attach_kpa_x10 and
//   has not fallen below detach_kpa_x10 since; without one, its pump has run attach_ms (it then
//   holds until the pump stops, without looking at the clock again).
// * MOTOR_STALL: |duty| >= 300 permille through five 100 ms windows with the count unchanged;
//   VACUUM_LOST: a holding cup stops holding with its pump on; LIMIT_HIT: a configured tube's
//   length crosses out of min_um - 2000 ..= max_um + 2000 (a tube configured while out crosses
//   out at the next tick). Each stops the motors. Every detection latches its bit and sends a
//   Fault report, whether the bit was latched already or not.
// * Reports go into an outbox that leech.ino drains into the serial port without blocking;
//   telemetry is skipped when it would leave no room for acks and faults. After SetTelemetry
//   the first report is due half a period after the Ack, then one every period.
#pragma once

#include <stdint.h>
#include "control.h"
#include "frame.h"

const uint16_t NO_SENSOR = 0xFFFF;

// Bit numbers of the faults (protocol 9.4); a Fault report's code is the bit number.
enum FaultCode : uint8_t {
    LINK_LOST = 0,
    MOTOR_STALL = 1,
    VACUUM_LOST = 2,
    LIMIT_HIT = 3,
    WATCHDOG_RESET = 4,
    BROWNOUT_RESET = 5,
};

// Frames waiting for the serial port, as a byte ring.
struct Outbox {
    static const uint8_t SIZE = 255;
    uint8_t bytes[SIZE];
    uint8_t head;  // next byte to send
    uint8_t count;

    uint8_t space() const { return SIZE - count; }
    // Frames and queues a message when its frame fits with `reserve` bytes to spare.
    bool put(const uint8_t *message, uint8_t len, uint8_t reserve);
    uint8_t pop();
};

struct Cup {
    bool pump_on;
    bool holding;
    uint32_t pump_since_ms;
    uint16_t vacuum_kpa_x10;  // last reading, or NO_SENSOR
};

struct Device {
    Tube tubes[3];
    int32_t raw_counts[3];  // last counts read, before the direction flag
    Cup cups[2];
    uint16_t attach_kpa_x10, detach_kpa_x10, attach_ms;
    uint16_t faults;
    uint16_t capabilities;
    uint16_t telemetry_period_ms;
    uint32_t next_telemetry_ms;
    bool link_armed;
    uint32_t link_last_ms;
    uint8_t last_seq;  // 0: none remembered
    uint8_t last_status, last_detail;
    uint16_t duplicates;
    // Stall and limit detection.
    uint32_t window_start_ms;
    uint8_t stall_windows[3];
    int32_t window_count[3];
    uint16_t window_min_duty[3];
    bool out_of_limits[3];
    Receiver rx;
    Outbox out;
};

extern Device dev;

// Power-up state; latches the reset-cause faults (bits of `reset_faults`) and sends the
// unsolicited DeviceHello (seq 0), then a Fault report for each of those faults.
void device_begin(uint16_t capabilities, uint16_t reset_faults, uint32_t now_ms);
// One byte from the serial line.
void device_receive(uint8_t byte, uint32_t now_ms);
// One control step: raw encoder counts and vacuum readings (NO_SENSOR without a sensor) now,
// and the control ticks elapsed since the previous step (1..=MAX_TICKS).
void device_tick(const int32_t raw_counts[3], const uint16_t vacuum_kpa_x10[2], uint32_t now_ms,
                 uint8_t ticks);
// The duty to apply to tube i's motor, permille, positive drives forward (reverse flag applied).
int16_t device_motor_duty(uint8_t i);
