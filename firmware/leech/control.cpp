// One tube's measurement and position loop (rules and units in control.h).
#include "control.h"

static const int32_t UM_PER_MM_X1000 = 1000000;
static const int32_t I32_MAX = 0x7FFFFFFF;
static const int32_t I32_MIN = -I32_MAX - 1;
// Where the P and D terms saturate, Q16 permille (8192 permille); the D term's before its
// scaling by TICK_HZ.
static const int32_t TERM_LIMIT_Q16 = (int32_t)1 << 29;
static const int32_t D_LIMIT_Q16 = TERM_LIMIT_Q16 >> TICK_SHIFT;

static int32_t saturate32(int64_t v) {
    return v > I32_MAX ? I32_MAX : (v < I32_MIN ? I32_MIN : (int32_t)v);
}

static int32_t clamp32(int32_t v, int32_t limit) {
    return v > limit ? limit : (v < -limit ? -limit : v);
}

static int32_t error_bound(int32_t bound) { return bound < 1 ? 1 : bound; }

// a - b saturated to the int32 range.
static int32_t difference(int32_t a, int32_t b) {
    int32_t d;
    if (__builtin_sub_overflow(a, b, &d)) return a < 0 ? I32_MIN : I32_MAX;
    return d;
}

// a + b saturated to the int32 range.
static int32_t sum(int32_t a, int32_t b) {
    int32_t s;
    if (__builtin_add_overflow(a, b, &s)) return a < 0 ? I32_MIN : I32_MAX;
    return s;
}

// The integral term (ki I) / 1024 in Q16 permille; |ki I| <= max_duty * 2^26 by the bound on I,
// so the result fits 32 bits.
static int32_t integral_term(int32_t ki_q16, int32_t integral) {
    return (int32_t)(((int64_t)ki_q16 * integral) >> TICK_SHIFT);
}

void Tube::configure(const TubeConfig &c, int32_t counts) {
    config = c;
    configured = true;
    uint32_t cpm = c.counts_per_mm_x1000;
    q1 = UM_PER_MM_X1000 / cpm;
    r1 = UM_PER_MM_X1000 % cpm;
    at = counts;
    int64_t x = (int64_t)counts * UM_PER_MM_X1000;
    quot = x / (int64_t)cpm;
    int64_t r = x % (int64_t)cpm;
    if (r < 0) {
        r += cpm;
        quot -= 1;
    }
    rem = (uint32_t)r;
    step_um = (int32_t)(c.max_speed_um_s >> TICK_SHIFT);
    step_frac = (uint16_t)(c.max_speed_um_s & (TICK_HZ - 1));
    // At least 1: a gain over the term's limit (kp_q16 > 2^29, kd_q16 > 2^19) would make the
    // bound 0 and silently turn its term off; with 1, the product (at most the gain, which fits
    // int32) is clamped in control() and the term saturates instead.
    p_error_max = c.kp_q16 > 0 ? error_bound(TERM_LIMIT_Q16 / c.kp_q16) : I32_MAX;
    d_error_max = c.kd_q16 > 0 ? error_bound(D_LIMIT_Q16 / c.kd_q16) : I32_MAX;
    // |ki I| / 1024 <= max_duty * 65536  <=>  |I| <= max_duty * 2^26 / ki.
    integral_max = c.ki_q16 > 0 ? saturate32(((int64_t)c.max_duty_permille << 26) / c.ki_q16) : 0;
    low_um = saturate32((int64_t)c.min_um - LIMIT_MARGIN_UM);
    high_um = saturate32((int64_t)c.max_um + LIMIT_MARGIN_UM);
    length_um = saturate32((int64_t)c.origin_um + quot + ((counts < 0 && rem != 0) ? 1 : 0));
}

void Tube::measure(int32_t counts) {
    if (!configured) {
        length_um = 0;
        return;
    }
    int32_t delta = counts - at;
    if (delta == 0) return;
    // A jump larger than the encoder can make in a tick (power-up, reconfiguration) is
    // recomputed by division; small steps walk.
    if (delta > 64 || delta < -64) {
        configure(config, counts);
        return;
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
    length_um = saturate32((int64_t)config.origin_um + quot + ((counts < 0 && rem != 0) ? 1 : 0));
}

void Tube::start(int32_t target) {
    if (!active) {
        setpoint_um = length_um;
        setpoint_frac = 0;
        integral = 0;
        last_error_um = 0;
        active = true;
    }
    target_um = target;
}

void Tube::control(uint8_t ticks) {
    if (!active) {
        duty_permille = 0;
        return;
    }
    // Setpoint ramp: a whole step per tick, plus one um each time the fractions add up to one
    // (step_frac * ticks + setpoint_frac < 1024 * 11, and step_um * ticks < 2^22 * 11: no
    // overflow for ticks <= MAX_TICKS).
    int32_t to_go = difference(target_um, setpoint_um);
    uint16_t frac = setpoint_frac + step_frac * ticks;
    int32_t step = step_um * ticks + (frac >> TICK_SHIFT);
    setpoint_frac = frac & (TICK_HZ - 1);
    if (to_go > step)
        setpoint_um += step;
    else if (to_go < -step)
        setpoint_um -= step;
    else {
        setpoint_um = target_um;
        setpoint_frac = 0;
    }

    int32_t error = difference(setpoint_um, length_um);
    int32_t de = difference(error, last_error_um);
    last_error_um = error;
    // Over several ticks: the error held through all of them (I), and the mean change per tick,
    // rounded (D). One 32-bit division, only on a tick that follows an overrun.
    int32_t error_sum = error;
    if (ticks > 1) {
        if (__builtin_mul_overflow(error, (int32_t)ticks, &error_sum)) error_sum = error < 0 ? I32_MIN : I32_MAX;
        int32_t half = ticks / 2;
        de = (de < 0 ? de - half : de + half) / ticks;
    }

    // The products fit int32 (|error| <= p_error_max, |de| <= d_error_max); the clamps matter
    // only for gains over the limits, whose error bound is 1 (configure).
    int32_t p = clamp32(config.kp_q16 * clamp32(error, p_error_max), TERM_LIMIT_Q16);
    int32_t d = clamp32(config.kd_q16 * clamp32(de, d_error_max), D_LIMIT_Q16) << TICK_SHIFT;
    int32_t pd = p + d;
    int32_t limit = (int32_t)config.max_duty_permille << 16;
    int32_t unclamped = pd + integral_term(config.ki_q16, integral);
    bool saturated = unclamped >= limit || unclamped <= -limit;
    bool same_sign = (unclamped > 0) == (error > 0);
    if (!saturated || !same_sign) {
        integral = clamp32(sum(integral, error_sum), integral_max);
        unclamped = pd + integral_term(config.ki_q16, integral);
    }
    int32_t duty = clamp32(unclamped, limit);
    duty_permille = (int16_t)((duty + 0x8000) >> 16);
}
