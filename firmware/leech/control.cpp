// One tube's measurement and position loop (rules and units in control.h).
#include "control.h"

static const int32_t UM_PER_MM_X1000 = 1000000;
static const int64_t TERM_LIMIT = (int64_t)1 << 46;

static int64_t clamp64(int64_t v, int64_t limit) {
    return v > limit ? limit : (v < -limit ? -limit : v);
}

static int32_t saturate32(int64_t v) {
    return v > INT32_MAX ? INT32_MAX : (v < INT32_MIN ? INT32_MIN : (int32_t)v);
}

void Tube::configure(const TubeConfig &c, int32_t counts) {
    config = c;
    configured = true;
    uint32_t cpm = c.counts_per_mm_x1000;
    q1 = UM_PER_MM_X1000 / cpm;
    r1 = UM_PER_MM_X1000 % cpm;
    // Forces a full recomputation at the next measure.
    at = counts;
    int64_t x = (int64_t)counts * UM_PER_MM_X1000;
    quot = x / (int64_t)cpm;
    int64_t r = x % (int64_t)cpm;
    if (r < 0) {
        r += cpm;
        quot -= 1;
    }
    rem = (uint32_t)r;
    // |ki I| / 2^26 <= max_duty  <=>  |I| <= max_duty * 2^26 / ki.
    integral_max = c.ki_q16 > 0 ? (((int64_t)c.max_duty_permille << 26) / c.ki_q16) : 0;
    measure(counts);
}

int32_t Tube::measure(int32_t counts) {
    if (!configured) {
        length_um = 0;
        return 0;
    }
    int32_t delta = counts - at;
    // A jump larger than the encoder can make in a tick (power-up, reconfiguration) is
    // recomputed by division; small steps walk.
    if (delta > 64 || delta < -64) {
        configure(config, counts);
        return length_um;
    }
    uint32_t cpm = config.counts_per_mm_x1000;
    for (; delta > 0; delta--) {
        quot += q1;
        if (rem >= cpm - r1) {
            rem -= cpm - r1;
            quot += 1;
        } else {
            rem += r1;
        }
    }
    for (; delta < 0; delta++) {
        quot -= q1;
        if (rem >= r1) {
            rem -= r1;
        } else {
            rem += cpm - r1;
            quot -= 1;
        }
    }
    at = counts;
    int64_t travel = quot + ((counts < 0 && rem != 0) ? 1 : 0);
    length_um = saturate32((int64_t)config.origin_um + travel);
    return length_um;
}

void Tube::start(int32_t target) {
    if (!active) {
        setpoint_q10 = (int64_t)length_um << TICK_SHIFT;
        integral = 0;
        last_error_um = 0;
        active = true;
    }
    target_um = target;
}

void Tube::control() {
    if (!active) {
        duty_permille = 0;
        return;
    }
    int64_t step = (int64_t)config.max_speed_um_s;
    int64_t to_go = ((int64_t)target_um << TICK_SHIFT) - setpoint_q10;
    setpoint_q10 += clamp64(to_go, step);

    int64_t setpoint_um = (setpoint_q10 + (1 << (TICK_SHIFT - 1))) >> TICK_SHIFT;
    int32_t error = saturate32(setpoint_um - length_um);
    int32_t de = saturate32((int64_t)error - last_error_um);
    last_error_um = error;

    int64_t p = clamp64((int64_t)config.kp_q16 * error, TERM_LIMIT >> 10) << 10;
    int64_t d = clamp64((int64_t)config.kd_q16 * de, TERM_LIMIT >> 20) << 20;
    int64_t pd = p + d;
    int64_t limit = (int64_t)config.max_duty_permille << 26;
    int64_t unclamped = pd + (int64_t)config.ki_q16 * integral;
    bool saturated = unclamped >= limit || unclamped <= -limit;
    bool same_sign = (unclamped > 0) == (error > 0);
    if (!saturated || !same_sign) {
        integral = clamp64(integral + error, integral_max);
        unclamped = pd + (int64_t)config.ki_q16 * integral;
    }
    int64_t duty = clamp64(unclamped, limit);
    duty_permille = (int16_t)((duty + ((int64_t)1 << 25)) >> 26);
}
