// One tube's measurement and position loop, as pure arithmetic (no hardware access).
//
// Units: um micrometres, counts encoder counts (direction flag applied), permille of full duty,
// Q16 = value * 65536, one tick = 1/TICK_HZ s = 1/1024 s (0.977 ms).
//
// * Length (protocol 6): length_um = origin_um + trunc(counts * 1000000 / counts_per_mm_x1000),
//   saturated to int32. A 64-bit division per tick is too slow on the AVR (about 1600 cycles
//   each), so the quotient is kept exactly and updated as the count moves:
//   counts * 1000000 = quot * cpm + rem with 0 <= rem < cpm (floor division), and one count
//   adds 1000000 = q1 * cpm + r1 to both sides. trunc = quot + 1 when counts < 0 and rem != 0.
// * Setpoint: moves toward the target by at most max_speed_um_s / TICK_HZ um per tick, kept
//   as whole um plus a fraction in 1/1024 um, so the speed is exact.
// * Elapsed time: a step normally covers one tick; after an overrun (ticks the loop could not
//   run in time) it covers all the ticks since the previous step, up to MAX_TICKS, so the
//   ramp and the I and D terms follow the true time.
// * PID: e = setpoint - length (um), I = sum of e over ticks (um tick = um s * 1024),
//   de = e - e_previous per tick (um per tick = um/s / 1024). The protocol's
//   duty = (kp_q16 e + ki_q16 I_um_s + kd_q16 D_um_s) / 65536 is, in Q16 permille,
//   kp e + (ki I) / 1024 + kd de * 1024, rounded to permille and clamped to +-max_duty_permille:
//   the tick rate being a power of two makes every scale a shift. The AVR has no 64-bit
//   arithmetic to spare at 1 kHz (a 64-bit multiply or shift costs hundreds of cycles), so the
//   P and D terms are computed in 32 bits from an error clamped, per configuration, where the
//   term reaches +-2^29 (8192 permille, over 8 times full duty), and the term clamped there too
//   (a gain over 2^29, or 2^19 for kd, gets an error bound of 1 and saturates the duty from one
//   um of error): the output is the same unless a P and a D term beyond that bound cancel.
//   Only ki I uses a 32 x 32 -> 64 multiply.
// * Anti-windup: the integral grows only while the output is not pushing further into
//   saturation, and |ki I| stays within max_duty_permille (the bound on I is precomputed per
//   configuration, and capped at the int32 range: only an integral gain under 0.0005 permille
//   per (um s) would need more).
#pragma once

#include <stdint.h>

const uint16_t TICK_HZ = 1024;
const uint8_t TICK_SHIFT = 10;  // log2(TICK_HZ)
// The most ticks one control step may cover (10 ms, the protocol's longest control period).
const uint8_t MAX_TICKS = 10;
// How far beyond its limits a tube may go before LIMIT_HIT (protocol 9.3), um.
const int32_t LIMIT_MARGIN_UM = 2000;

// ConfigureTube's fields (protocol 4.3).
struct TubeConfig {
    bool reverse_motor;
    bool reverse_encoder;
    uint32_t counts_per_mm_x1000;
    int32_t origin_um;
    int32_t min_um;
    int32_t max_um;
    uint32_t max_speed_um_s;
    uint16_t max_duty_permille;
    int32_t kp_q16;
    int32_t ki_q16;
    int32_t kd_q16;
};

struct Tube {
    bool configured;
    bool active;  // under position control
    TubeConfig config;
    // counts * 1000000 = quot * cpm + rem, for the count `at` (see the header).
    int32_t at;
    int64_t quot;
    uint32_t rem;
    uint32_t q1, r1;
    // Per configuration: the setpoint's whole um and 1/1024 um per tick, the errors beyond
    // which the P and D terms saturate, the bound on the integral, the limits with margin.
    int32_t step_um;
    uint16_t step_frac;
    int32_t p_error_max, d_error_max;
    int32_t integral_max;
    int32_t low_um, high_um;
    int32_t target_um;
    int32_t setpoint_um;
    uint16_t setpoint_frac;
    int32_t integral;
    int32_t last_error_um;
    int32_t length_um;
    int16_t duty_permille;

    // Takes a new configuration (checked by the caller) with the tube's count now.
    void configure(const TubeConfig &c, int32_t counts);
    // Measures the length at `counts` into length_um.
    void measure(int32_t counts);
    // Enters position control toward target_um (the setpoint starts at the measured length
    // when it was not under control), or takes a new target.
    void start(int32_t target);
    // One position-loop step covering `ticks` ticks (1..=MAX_TICKS; after measure); sets
    // duty_permille.
    void control(uint8_t ticks);
};
