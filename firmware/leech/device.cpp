// The device side of the LEeCH protocol 1.0 (rules in device.h, layouts in docs/protocol.md 4).
#include "device.h"

#include <string.h>

Device dev;

// Message types (protocol 4.2).
enum : uint8_t {
    T_HELLO = 0x01,
    T_HEARTBEAT = 0x02,
    T_STOP = 0x03,
    T_SET_LENGTHS = 0x04,
    T_JOG = 0x05,
    T_PUMP = 0x06,
    T_SET_TELEMETRY = 0x07,
    T_CLEAR_FAULTS = 0x08,
    T_CONFIGURE_TUBE = 0x09,
    T_CONFIGURE_CUPS = 0x0A,
    T_ACK = 0x80,
    T_DEVICE_HELLO = 0x81,
    T_TELEMETRY = 0x82,
    T_FAULT = 0x83,
};

// Ack statuses and refusal reasons (protocol 4.4, 4.5).
enum : uint8_t { S_OK = 0, S_REFUSED = 1, S_UNKNOWN_TYPE = 2, S_BAD_LENGTH = 3, S_BAD_VALUE = 4 };
enum : uint8_t {
    R_LAST_CUP = 1,
    R_NOT_HOLDING = 2,
    R_OUT_OF_RANGE = 3,
    R_FAULTED = 4,
    R_BAD_STATE = 5,
    R_NOT_CONFIGURED = 6,
};

static const uint8_t PROTOCOL_MAJOR = 1, PROTOCOL_MINOR = 0;
static const uint8_t FIRMWARE_MAJOR = 0, FIRMWARE_MINOR = 1, FIRMWARE_PATCH = 0;
static const uint8_t DEVICE_KIND_MEGA = 1;

static const uint32_t LINK_TIMEOUT_MS = 500;
static const uint16_t MIN_TELEMETRY_PERIOD_MS = 10;
static const uint16_t STALL_DUTY_PERMILLE = 300;
static const uint8_t STALL_WINDOWS = 5;
static const uint32_t STALL_WINDOW_MS = 100;

// Frames of acks, faults and hellos (8, 10 and 14 bytes) that telemetry must leave room for.
static const uint8_t REPORT_RESERVE = 48;

// ---- byte order (little-endian, protocol 1) ----

static uint16_t get_u16(const uint8_t *p) { return p[0] | ((uint16_t)p[1] << 8); }
static uint32_t get_u32(const uint8_t *p) {
    return p[0] | ((uint32_t)p[1] << 8) | ((uint32_t)p[2] << 16) | ((uint32_t)p[3] << 24);
}
static int32_t get_i32(const uint8_t *p) { return (int32_t)get_u32(p); }
static uint8_t *put_u16(uint8_t *p, uint16_t v) {
    p[0] = (uint8_t)v;
    p[1] = (uint8_t)(v >> 8);
    return p + 2;
}
static uint8_t *put_u32(uint8_t *p, uint32_t v) {
    p = put_u16(p, (uint16_t)v);
    return put_u16(p, (uint16_t)(v >> 16));
}

// ---- outbox ----

bool Outbox::put(const uint8_t *message, uint8_t len, uint8_t reserve) {
    uint8_t frame[MAX_FRAME];
    uint8_t n = frame_encode(message, len, frame);
    if ((uint16_t)n + reserve > space()) return false;
    uint8_t tail = (uint8_t)((head + count) % SIZE);
    for (uint8_t i = 0; i < n; i++) {
        bytes[tail] = frame[i];
        tail = tail + 1 == SIZE ? 0 : tail + 1;
    }
    count += n;
    return true;
}

uint8_t Outbox::pop() {
    uint8_t b = bytes[head];
    head = head + 1 == SIZE ? 0 : head + 1;
    count--;
    return b;
}

// ---- reports ----

static void send_ack(uint8_t seq, uint8_t status, uint8_t detail) {
    uint8_t m[4] = {T_ACK, seq, status, detail};
    dev.out.put(m, sizeof m, 0);
}

static void send_hello(uint8_t seq) {
    uint8_t m[10] = {T_DEVICE_HELLO, seq, PROTOCOL_MAJOR, PROTOCOL_MINOR, FIRMWARE_MAJOR,
                     FIRMWARE_MINOR, FIRMWARE_PATCH, DEVICE_KIND_MEGA};
    put_u16(m + 8, dev.capabilities);
    dev.out.put(m, sizeof m, 0);
}

// Latches a fault and reports it. Every detection is reported, latched already or not, so that a
// second link loss or stall is news to the host before anyone cleared the first (protocol 9.4).
static void raise(uint8_t code, uint8_t detail, uint32_t now_ms) {
    dev.faults |= (uint16_t)1 << code;
    uint8_t m[8] = {T_FAULT, 0};
    put_u32(m + 2, now_ms);
    m[6] = code;
    m[7] = detail;
    dev.out.put(m, sizeof m, 0);
}

static void send_telemetry(uint32_t now_ms) {
    uint8_t m[54] = {T_TELEMETRY, 0};
    uint8_t *p = put_u32(m + 2, now_ms);
    uint8_t pumps = 0, holding = 0, active = 0, configured = 0;
    for (uint8_t i = 0; i < 3; i++) {
        const Tube &t = dev.tubes[i];
        int32_t raw = dev.raw_counts[i];
        p = put_u32(p, (uint32_t)(t.configured && t.config.reverse_encoder ? -raw : raw));
        active |= (uint8_t)t.active << i;
        configured |= (uint8_t)t.configured << i;
    }
    for (uint8_t i = 0; i < 3; i++) p = put_u32(p, (uint32_t)dev.tubes[i].length_um);
    for (uint8_t i = 0; i < 3; i++) p = put_u16(p, (uint16_t)dev.tubes[i].duty_permille);
    for (uint8_t c = 0; c < 2; c++) {
        p = put_u16(p, dev.cups[c].vacuum_kpa_x10);
        pumps |= (uint8_t)dev.cups[c].pump_on << c;
        holding |= (uint8_t)dev.cups[c].holding << c;
    }
    p = put_u16(p, dev.faults);
    p = put_u16(p, dev.rx.rx_frames);
    p = put_u16(p, dev.rx.bad_crc);
    p = put_u16(p, dev.rx.bad_frames);
    p = put_u16(p, dev.duplicates);
    p[0] = pumps;
    p[1] = holding;
    p[2] = active;
    p[3] = configured;
    dev.out.put(m, sizeof m, REPORT_RESERVE);
}

// ---- commands ----

static void stop_motors() {
    for (uint8_t i = 0; i < 3; i++) {
        dev.tubes[i].active = false;
        dev.tubes[i].duty_permille = 0;
    }
}

// The refusals of a motion command in the protocol's order, for the tubes in the bit set
// `tubes` going to `targets` (um, 64 bits: a jog may leave the int32 range).
static uint8_t check_motion(uint8_t tubes, const int64_t targets[3]) {
    for (uint8_t i = 0; i < 3; i++)
        if ((tubes >> i & 1) && !dev.tubes[i].configured) return R_NOT_CONFIGURED;
    if (dev.faults & (1 << MOTOR_STALL)) return R_FAULTED;
    for (uint8_t i = 0; i < 3; i++) {
        if (!(tubes >> i & 1)) continue;
        const TubeConfig &c = dev.tubes[i].config;
        if (targets[i] < c.min_um || targets[i] > c.max_um) return R_OUT_OF_RANGE;
    }
    return 0;
}

// The last-cup rule (protocol 9.2): 0 when Pump{cup, on} is allowed, else the reason.
static uint8_t last_cup_refusal(uint8_t cup, bool on) {
    const Cup &self = dev.cups[cup], &other = dev.cups[cup ^ 1];
    if (on || !self.holding || other.holding) return 0;
    return other.pump_on ? R_NOT_HOLDING : R_LAST_CUP;
}

// Executes a decoded command; returns its refusal reason, 0 when carried out.
static uint8_t execute(uint8_t type, const uint8_t *b, uint32_t now_ms) {
    switch (type) {
    case T_HEARTBEAT:
        return 0;
    case T_STOP:
        stop_motors();
        return 0;
    case T_SET_LENGTHS: {
        int64_t targets[3];
        for (uint8_t i = 0; i < 3; i++) targets[i] = get_i32(b + 4 * i);
        uint8_t refusal = check_motion(0b111, targets);
        if (refusal) return refusal;
        for (uint8_t i = 0; i < 3; i++) dev.tubes[i].start((int32_t)targets[i]);
        return 0;
    }
    case T_JOG: {
        uint8_t i = b[0];
        Tube &t = dev.tubes[i];
        int64_t targets[3] = {0, 0, 0};
        targets[i] = (int64_t)(t.active ? t.target_um : t.length_um) + get_i32(b + 1);
        uint8_t refusal = check_motion(1 << i, targets);
        if (refusal) return refusal;
        t.start((int32_t)targets[i]);
        return 0;
    }
    case T_PUMP: {
        uint8_t c = b[0];
        bool on = b[1];
        uint8_t refusal = last_cup_refusal(c, on);
        if (refusal) return refusal;
        Cup &cup = dev.cups[c];
        if (on && !cup.pump_on) cup.pump_since_ms = now_ms;
        cup.pump_on = on;
        if (!on) cup.holding = false;
        return 0;
    }
    case T_SET_TELEMETRY: {
        uint16_t period = get_u16(b);
        if (period != 0 && period < MIN_TELEMETRY_PERIOD_MS) return R_OUT_OF_RANGE;
        dev.telemetry_period_ms = period;
        // The first report is due half a period after the Ack (protocol section 8: within one
        // period). At now + period it came up to a tick and a step of millis() late; the other
        // half (5 ms or more) absorbs those (under 1 and 2 ms) and a late loop. Not at once,
        // so that a command sent right behind SetTelemetry is still answered first, as by the
        // reference device (the protocol suite checks it).
        dev.next_telemetry_ms = now_ms + period / 2;
        return 0;
    }
    case T_CLEAR_FAULTS:
        dev.faults &= ~get_u16(b);
        return 0;
    case T_CONFIGURE_TUBE: {
        uint8_t i = b[0];
        if (dev.tubes[i].active) return R_BAD_STATE;
        TubeConfig c;
        c.reverse_motor = b[1] & 1;
        c.reverse_encoder = b[1] & 2;
        c.counts_per_mm_x1000 = get_u32(b + 2);
        c.origin_um = get_i32(b + 6);
        c.min_um = get_i32(b + 10);
        c.max_um = get_i32(b + 14);
        c.max_speed_um_s = get_u32(b + 18);
        c.max_duty_permille = get_u16(b + 22);
        c.kp_q16 = get_i32(b + 24);
        c.ki_q16 = get_i32(b + 28);
        c.kd_q16 = get_i32(b + 32);
        if (c.counts_per_mm_x1000 < 1 || c.min_um > c.max_um || c.max_speed_um_s < 1 ||
            c.max_duty_permille < 1 || c.max_duty_permille > 1000 || c.kp_q16 < 0 || c.ki_q16 < 0 ||
            c.kd_q16 < 0)
            return R_OUT_OF_RANGE;
        int32_t raw = dev.raw_counts[i];
        dev.tubes[i].configure(c, c.reverse_encoder ? -raw : raw);
        // A tube configured out of its new limits crosses out at the next tick (protocol 9.3),
        // even if it was already out under the old configuration.
        dev.out_of_limits[i] = false;
        return 0;
    }
    case T_CONFIGURE_CUPS: {
        uint16_t attach = get_u16(b), detach = get_u16(b + 2);
        if (attach < 1 || detach > attach) return R_OUT_OF_RANGE;
        dev.attach_kpa_x10 = attach;
        dev.detach_kpa_x10 = detach;
        dev.attach_ms = get_u16(b + 4);
        return 0;
    }
    }
    return 0;
}

// Body lengths of the commands 0x01..=0x0A (protocol 4.2).
static const uint8_t BODY_LEN[] = {0, 0, 0, 12, 5, 2, 2, 2, 36, 6};

// Decodes (protocol 4.6) and carries out one new command; returns the Ack status and sets its
// detail.
static uint8_t decode_and_execute(const uint8_t *m, uint8_t len, uint8_t *detail, uint32_t now_ms) {
    uint8_t type = m[0];
    const uint8_t *body = m + 2;
    *detail = 0;
    if (type < T_HELLO || type > T_CONFIGURE_CUPS) return S_UNKNOWN_TYPE;
    uint8_t expected = BODY_LEN[type - 1];
    if (len - 2 != expected) {
        *detail = expected;
        return S_BAD_LENGTH;
    }
    // Closed sets, at their body offsets: tube (Jog 0, ConfigureTube 0), cup (Pump 0), on (Pump 1).
    if ((type == T_JOG || type == T_CONFIGURE_TUBE) && body[0] > 2) return S_BAD_VALUE;
    if (type == T_PUMP && body[0] > 1) return S_BAD_VALUE;
    if (type == T_PUMP && body[1] > 1) {
        *detail = 1;
        return S_BAD_VALUE;
    }
    uint8_t refusal = execute(type, body, now_ms);
    *detail = refusal;
    return refusal ? S_REFUSED : S_OK;
}

// One message whose CRC matched (protocol 5, "Device processing of one valid frame").
static void handle(const uint8_t *m, uint8_t len, uint32_t now_ms) {
    uint8_t seq = m[1];
    // Only a frame from a host restarts the link timer (protocol 9.1): report types (0x80..0xFF)
    // and seq 0 never do, so a line echoing the device's own reports cannot keep a dead link alive.
    if (m[0] < 0x80 && seq != 0) {
        dev.link_armed = true;
        dev.link_last_ms = now_ms;
    }
    // Unanswerable (seq 0), or a report type: never answered, so that a line echoing the
    // device's own answers back cannot make it answer them for ever (protocol 4.6).
    if (seq == 0 || m[0] >= 0x80) {
        dev.rx.bad_frames++;
        return;
    }
    if (m[0] == T_HELLO && len == 2) {
        dev.last_seq = 0;
        send_hello(seq);
        return;
    }
    if (dev.last_seq != 0 && seq == dev.last_seq) {
        dev.duplicates++;
        send_ack(seq, dev.last_status, dev.last_detail);
        return;
    }
    uint8_t detail;
    uint8_t status = decode_and_execute(m, len, &detail, now_ms);
    dev.last_seq = seq;
    dev.last_status = status;
    dev.last_detail = detail;
    send_ack(seq, status, detail);
}

void device_receive(uint8_t byte, uint32_t now_ms) {
    uint8_t len = dev.rx.push(byte);
    if (len) handle(dev.rx.message, len, now_ms);
}

// ---- power-up and the control tick ----

void device_begin(uint16_t capabilities, uint16_t reset_faults, uint32_t now_ms) {
    memset(&dev, 0, sizeof dev);
    dev.capabilities = capabilities;
    dev.attach_kpa_x10 = 300;
    dev.detach_kpa_x10 = 200;
    dev.attach_ms = 1000;
    dev.window_start_ms = now_ms;
    for (uint8_t c = 0; c < 2; c++) dev.cups[c].vacuum_kpa_x10 = (capabilities >> c & 1) ? 0 : NO_SENSOR;
    send_hello(0);
    for (uint8_t code = WATCHDOG_RESET; code <= BROWNOUT_RESET; code++)
        if (reset_faults >> code & 1) raise(code, 0, now_ms);
}

// Holding, VACUUM_LOST (protocol 9.2, 9.3).
static void run_cups(const uint16_t vacuum[2], uint32_t now_ms) {
    for (uint8_t c = 0; c < 2; c++) {
        Cup &cup = dev.cups[c];
        cup.vacuum_kpa_x10 = vacuum[c];
        bool holds;
        if (!cup.pump_on)
            holds = false;
        else if (vacuum[c] == NO_SENSOR)
            // Once it holds it keeps holding while the pump runs (the pump has then been on for
            // at least attach_ms whatever the clock says): re-testing the elapsed time would drop
            // holding when the u32 difference wraps, after 49.7 days.
            holds = cup.holding || now_ms - cup.pump_since_ms >= dev.attach_ms;
        else
            holds = vacuum[c] >= (cup.holding ? dev.detach_kpa_x10 : dev.attach_kpa_x10);
        bool lost = cup.holding && !holds && cup.pump_on;
        cup.holding = holds;
        if (lost) {
            stop_motors();
            raise(VACUUM_LOST, c, now_ms);
        }
    }
}

// LIMIT_HIT and MOTOR_STALL for tube i (protocol 9.3); `window_end` closes a 100 ms window.
static void check_tube(uint8_t i, int32_t counts, bool window_end, uint32_t now_ms) {
    Tube &t = dev.tubes[i];
    bool limit_hit = false;
    if (t.configured) {
        bool out = t.length_um < t.low_um || t.length_um > t.high_um;
        limit_hit = out && !dev.out_of_limits[i];
        dev.out_of_limits[i] = out;
    }
    int16_t duty = t.duty_permille;
    uint16_t magnitude = duty < 0 ? -duty : duty;
    if (magnitude < dev.window_min_duty[i]) dev.window_min_duty[i] = magnitude;
    bool stalled = false;
    if (window_end) {
        bool hard = dev.window_min_duty[i] >= STALL_DUTY_PERMILLE;
        bool still = counts == dev.window_count[i];
        dev.stall_windows[i] = hard && still ? dev.stall_windows[i] + 1 : 0;
        stalled = dev.stall_windows[i] >= STALL_WINDOWS;
        dev.window_count[i] = counts;
        dev.window_min_duty[i] = UINT16_MAX;
    }
    if (limit_hit) {
        stop_motors();
        raise(LIMIT_HIT, i, now_ms);
    }
    if (stalled) {
        dev.stall_windows[i] = 0;
        stop_motors();
        raise(MOTOR_STALL, i, now_ms);
    }
}

void device_tick(const int32_t raw_counts[3], const uint16_t vacuum[2], uint32_t now_ms, uint8_t ticks) {
    if (dev.link_armed && now_ms - dev.link_last_ms >= LINK_TIMEOUT_MS) {
        dev.link_armed = false;
        stop_motors();
        // Forget the remembered seq, so the first command after the loss is carried out even if
        // the host's seq has wrapped round to it meanwhile (protocol 5).
        dev.last_seq = 0;
        raise(LINK_LOST, 0, now_ms);
    }
    bool window_end = now_ms - dev.window_start_ms >= STALL_WINDOW_MS;
    if (window_end) dev.window_start_ms += STALL_WINDOW_MS;
    for (uint8_t i = 0; i < 3; i++) {
        Tube &t = dev.tubes[i];
        dev.raw_counts[i] = raw_counts[i];
        int32_t counts = t.configured && t.config.reverse_encoder ? -raw_counts[i] : raw_counts[i];
        t.measure(counts);
        t.control(ticks);
        check_tube(i, counts, window_end, now_ms);
    }
    run_cups(vacuum, now_ms);
    if (dev.telemetry_period_ms != 0 && (int32_t)(now_ms - dev.next_telemetry_ms) >= 0) {
        dev.next_telemetry_ms += dev.telemetry_period_ms;
        // After a stall of the loop, resume the period from now instead of sending a burst.
        if ((int32_t)(now_ms - dev.next_telemetry_ms) >= 0) dev.next_telemetry_ms = now_ms + dev.telemetry_period_ms;
        send_telemetry(now_ms);
    }
}

int16_t device_motor_duty(uint8_t i) {
    const Tube &t = dev.tubes[i];
    return t.config.reverse_motor ? -t.duty_permille : t.duty_permille;
}
