// LEeCH soft climbing robot controller: Arduino Mega 2560 (ATmega2560, 16 MHz) firmware speaking
// the LEeCH host-controller protocol 1.0 (docs/protocol.md) over Serial (USB, 115200 8N1).
// Pins, wiring, build and flashing: docs/firmware.md.
//
// This file holds the hardware: pin map, encoder interrupts, the control tick timer, PWM and
// direction outputs, pumps, vacuum sensors, watchdog and sleep. The protocol logic is in
// device.cpp, the position loop in control.cpp, the framing in frame.cpp.
//
// * Encoders: x4 quadrature, every edge of A or B is one count, counted in INT0..INT5 (any
//   edge). With state = A * 2 + B, 0 -> 2 -> 3 -> 1 -> 0 (A leads B) counts +1, the reverse -1,
//   a jump of both channels (a missed edge) 0.
// * Control tick: Timer5 in CTC mode, prescaler 1, 15625 cycles = 1/1024 s (0.977 ms). The
//   interrupt only counts the tick; loop() runs the position loop of the three tubes, the cups
//   and the fault checks, so that long 64-bit arithmetic never delays the UART or the encoders.
// * Motors: TB6612FNG-like, IN1=H IN2=L forward (lengthens), IN1=L IN2=H backward, IN1=IN2=H
//   short brake (duty 0 and stopped tubes: the tubes are not back-driven). PWM duty =
//   OCR / 255 with OCR = round(|duty_permille| * 255 / 1000), 8-bit phase-correct PWM at
//   16 MHz / 510 = 31.4 kHz (prescaler 1: above hearing).
// * Vacuum sensors (MPXV6115V-like, ratiometric to 5 V, V = 0.2 V + 4.5 V * kPa / 115):
//   vacuum_kpa_x10 = max(0, adc * 5000 / 1023 - 200) * 1150 / 4500, adc 0..1023 against AVcc.
//   One free-running conversion per tick, channels alternating (each cup read at 512 Hz).
// * Watchdog: interrupt-and-system-reset mode at 120 ms, reset every loop. Its first time-out
//   runs an interrupt that leaves a marker in .noinit RAM, the second resets the chip: a hung
//   loop is reset within two time-outs, 240 ms nominal (the watchdog's 128 kHz oscillator is
//   only typical). At boot the marker, or MCUSR's WDRF, means WATCHDOG_RESET; MCUSR's BORF
//   means BROWNOUT_RESET (see "reset cause" below).
// * Idle: SLEEP_MODE_IDLE until the next interrupt (tick, millis, UART, encoder).

#include <avr/sleep.h>
#include <avr/wdt.h>
#include <util/atomic.h>

#include "device.h"

// ---- build options: comment a sensor out when it is not fitted; that cup then holds after its
// pump has run attach_ms, and its telemetry reads 0xFFFF ----
#define LEECH_REAR_VACUUM_SENSOR
#define LEECH_FRONT_VACUUM_SENSOR

// ---- pin map (Arduino pin numbers; the AVR port bits used by the fast paths below are the
// same pins, see docs/firmware.md) ----
const uint8_t PIN_PWM[3] = {5, 6, 7};      // L1 OC3A (PE3), L2 OC4A (PH3), L3 OC4B (PH4)
const uint8_t PIN_IN1[3] = {22, 24, 26};   // PA0, PA2, PA4
const uint8_t PIN_IN2[3] = {23, 25, 27};   // PA1, PA3, PA5
const uint8_t PIN_ENC_A[3] = {2, 18, 20};  // L1 PE4 INT4, L2 PD3 INT3, L3 PD1 INT1
const uint8_t PIN_ENC_B[3] = {3, 19, 21};  // L1 PE5 INT5, L2 PD2 INT2, L3 PD0 INT0
const uint8_t PIN_PUMP[2] = {8, 9};        // rear PH5, front PH6; active high (MOSFET gate)
const uint8_t ADC_VACUUM[2] = {0, 1};      // rear A0, front A1 (ADC channels)
const uint8_t PIN_LED = 13;                // PB7: lit while the host's link is up

// Fast paths: the PWM compare registers of PIN_PWM, the port of PIN_IN1/PIN_IN2 (IN1 of motor i
// is bit 2i, IN2 bit 2i+1), and each encoder's state A * 2 + B read from its port.
#define PWM_OCR_L1 OCR3A
#define PWM_OCR_L2 OCR4A
#define PWM_OCR_L3 OCR4B
#define MOTOR_DIR_PORT PORTA
#define ENC_L1_STATE() ((uint8_t)(((PINE >> 3) & 2) | ((PINE >> 5) & 1)))  // A PE4, B PE5
#define ENC_L2_STATE() ((uint8_t)((PIND >> 2) & 3))                        // A PD3, B PD2
#define ENC_L3_STATE() ((uint8_t)(PIND & 3))                               // A PD1, B PD0

const uint16_t TICK_TIMER_TOP = F_CPU / TICK_HZ - 1;  // 15624

// ---- reset cause: saved before the C runtime starts, then the watchdog is disarmed (after a
// watchdog reset it stays enabled at 16 ms) ----
// The Mega's stock stk500v2 bootloader clears MCUSR before it jumps to the sketch, so WDRF alone
// never tells a watchdog reset there. The watchdog's interrupt therefore leaves
// WATCHDOG_MARKER in watchdog_marker (.noinit: neither the reset nor the C runtime clears it)
// one time-out before the reset; at boot the marker means the watchdog's reset, whatever MCUSR
// says. It is 32 bits so that the RAM's random content at power-up matches it with a chance of
// 2^-32. It sits above .data and .bss, clear of the bootloader's few hundred bytes of variables
// at the bottom of RAM and of its stack at the top. MCUSR is still read: a bootloader that
// passes it on (Optiboot) reports WDRF too, and BORF, the only record of a brown-out.
const uint32_t WATCHDOG_MARKER = 0x57444F47;  // "WDOG"
uint8_t reset_cause __attribute__((section(".noinit")));
volatile uint32_t watchdog_marker __attribute__((section(".noinit")));
void save_reset_cause(void) __attribute__((naked, used, section(".init3")));
void save_reset_cause(void) {
    reset_cause = MCUSR;
    if (watchdog_marker == WATCHDOG_MARKER) reset_cause |= 1 << WDRF;
    watchdog_marker = 0;
    MCUSR = 0;
    wdt_disable();
}

// The first time-out of a loop that stopped resetting the watchdog. Entering this vector
// clears WDIE in hardware, so the next time-out resets the chip; WDIE is set again only by
// loop() (watchdog_check), never here, so that a hang cannot re-arm the interrupt for ever.
ISR(WDT_vect) { watchdog_marker = WATCHDOG_MARKER; }

// Watchdog in interrupt-and-system-reset mode (WDE + WDIE), 120 ms (WDP1 + WDP0), with the
// timed sequence (WDCE + WDE, then the new value within four cycles).
static void watchdog_start() {
    ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
        wdt_reset();
        WDTCSR = (1 << WDCE) | (1 << WDE);
        WDTCSR = (1 << WDIE) | (1 << WDE) | (1 << WDP1) | (1 << WDP0);
    }
}

// Resets the watchdog. If its interrupt ran (a loop pass took over 120 ms but the loop came
// back), the marker is withdrawn and the interrupt armed again: otherwise the next time-out
// would reset at once, and a later reset of another cause would read as the watchdog's.
static void watchdog_check() {
    wdt_reset();
    if (!(WDTCSR & (1 << WDIE))) {
        watchdog_marker = 0;
        watchdog_start();
    }
}

// ---- encoders ----
volatile int32_t encoder_counts[3];
volatile uint8_t encoder_state[3];
// Count change by (previous state << 2 | new state).
const int8_t QUADRATURE[16] = {0, -1, 1, 0, 1, 0, 0, -1, -1, 0, 0, 1, 0, 1, -1, 0};

static inline void encoder_edge(uint8_t i, uint8_t state) {
    encoder_counts[i] += QUADRATURE[(encoder_state[i] << 2) | state];
    encoder_state[i] = state;
}

ISR(INT4_vect) { encoder_edge(0, ENC_L1_STATE()); }
ISR(INT5_vect, ISR_ALIASOF(INT4_vect));
ISR(INT3_vect) { encoder_edge(1, ENC_L2_STATE()); }
ISR(INT2_vect, ISR_ALIASOF(INT3_vect));
ISR(INT1_vect) { encoder_edge(2, ENC_L3_STATE()); }
ISR(INT0_vect, ISR_ALIASOF(INT1_vect));

// ---- control tick ----
volatile uint8_t ticks_pending;
ISR(TIMER5_COMPA_vect) { ticks_pending++; }

// ---- vacuum sensors ----
uint16_t vacuum_kpa_x10[2] = {NO_SENSOR, NO_SENSOR};
uint8_t adc_cup;  // the cup whose conversion is running
uint16_t adc_last[2];  // the readings vacuum_kpa_x10 was computed from

static bool has_sensor(uint8_t cup) {
#ifdef LEECH_REAR_VACUUM_SENSOR
    if (cup == 0) return true;
#endif
#ifdef LEECH_FRONT_VACUUM_SENSOR
    if (cup == 1) return true;
#endif
    return false;
}

static void adc_start(uint8_t cup) {
    adc_cup = cup;
    ADMUX = (1 << REFS0) | ADC_VACUUM[cup];  // AVcc reference
    ADCSRB &= ~(1 << MUX5);
    ADCSRA |= (1 << ADSC);
}

// Takes the finished conversion, if any, and starts the next sensor's. The conversion to
// 0.1 kPa (two 32-bit divisions, about 1100 cycles) runs only when the reading changed.
static void adc_poll() {
    if (!has_sensor(0) && !has_sensor(1)) return;
    if (ADCSRA & (1 << ADSC)) return;
    uint16_t adc = ADC;
    if (adc != adc_last[adc_cup]) {
        adc_last[adc_cup] = adc;
        int32_t mv = (int32_t)adc * 5000 / 1023 - 200;
        vacuum_kpa_x10[adc_cup] = (uint16_t)((mv < 0 ? 0 : mv) * 1150 / 4500);
    }
    uint8_t next = adc_cup ^ 1;
    adc_start(has_sensor(next) ? next : adc_cup);
}

// ---- outputs ----
int16_t motor_duty[3];  // last duty applied, permille

static void drive_motor(uint8_t i, int16_t duty) {
    if (duty == motor_duty[i]) return;
    motor_duty[i] = duty;
    uint8_t in1 = 1 << (2 * i), in2 = 1 << (2 * i + 1);
    uint16_t magnitude = duty < 0 ? -duty : duty;
    // round(magnitude * 255 / 1000) for 0..1000, without a 32-bit division (checked for every
    // value: 16712 / 65536 = 0.2550049).
    uint8_t pwm = (uint8_t)(((uint32_t)magnitude * 16712 + 32768) >> 16);
    uint8_t dir = duty > 0 ? in1 : (duty < 0 ? in2 : in1 | in2);
    MOTOR_DIR_PORT = (MOTOR_DIR_PORT & ~(in1 | in2)) | dir;
    switch (i) {
    case 0: PWM_OCR_L1 = pwm; break;
    case 1: PWM_OCR_L2 = pwm; break;
    default: PWM_OCR_L3 = pwm; break;
    }
}

static void apply_outputs() {
    for (uint8_t i = 0; i < 3; i++) drive_motor(i, device_motor_duty(i));
    for (uint8_t c = 0; c < 2; c++) digitalWrite(PIN_PUMP[c], dev.cups[c].pump_on ? HIGH : LOW);
    digitalWrite(PIN_LED, dev.link_armed ? HIGH : LOW);
}

// Moves queued report bytes into Serial's transmit buffer, never more than it has room for,
// so that Serial.write never blocks.
static void flush_reports() {
    int room = Serial.availableForWrite();
    while (room-- > 0 && dev.out.count > 0) Serial.write(dev.out.pop());
}

void setup() {
    // Brake (IN1 = IN2 = high) in PORT before the IN pins become outputs: the other order drives
    // them low first, a moment of coast.
    MOTOR_DIR_PORT |= 0x3F;
    for (uint8_t i = 0; i < 3; i++) {
        pinMode(PIN_IN1[i], OUTPUT);
        pinMode(PIN_IN2[i], OUTPUT);
        pinMode(PIN_PWM[i], OUTPUT);
        pinMode(PIN_ENC_A[i], INPUT_PULLUP);
        pinMode(PIN_ENC_B[i], INPUT_PULLUP);
    }
    for (uint8_t c = 0; c < 2; c++) pinMode(PIN_PUMP[c], OUTPUT);
    pinMode(PIN_LED, OUTPUT);

    // PWM: 8-bit phase-correct (WGM 1), non-inverting on OC3A, OC4A, OC4B, prescaler 1.
    TCCR3A = (1 << COM3A1) | (1 << WGM30);
    TCCR3B = (1 << CS30);
    TCCR4A = (1 << COM4A1) | (1 << COM4B1) | (1 << WGM40);
    TCCR4B = (1 << CS40);

    uint16_t faults = 0;
    if (reset_cause & (1 << WDRF)) faults |= 1 << WATCHDOG_RESET;
    if (reset_cause & (1 << BORF)) faults |= 1 << BROWNOUT_RESET;
    uint16_t capabilities = (has_sensor(0) ? 1 : 0) | (has_sensor(1) ? 2 : 0);
    device_begin(capabilities, faults, millis());
    for (uint8_t c = 0; c < 2; c++) vacuum_kpa_x10[c] = has_sensor(c) ? 0 : NO_SENSOR;

    encoder_state[0] = ENC_L1_STATE();
    encoder_state[1] = ENC_L2_STATE();
    encoder_state[2] = ENC_L3_STATE();
    // Any edge on INT0..INT5 (ISCn = 01).
    EICRA = (1 << ISC00) | (1 << ISC10) | (1 << ISC20) | (1 << ISC30);
    EICRB = (1 << ISC40) | (1 << ISC50);
    EIFR = 0x3F;
    EIMSK = 0x3F;

    if (has_sensor(0) || has_sensor(1)) adc_start(has_sensor(0) ? 0 : 1);

    // Control tick: Timer5 CTC (WGM 4) on OCR5A, prescaler 1.
    TCCR5A = 0;
    TCCR5B = (1 << WGM52) | (1 << CS50);
    OCR5A = TICK_TIMER_TOP;
    TIMSK5 = (1 << OCIE5A);

    Serial.begin(115200);
    flush_reports();
    watchdog_start();
}

void loop() {
    watchdog_check();
#ifdef LEECH_TEST_HANG
    // Test build only (docs/firmware.md, "Watchdog and reset causes"): the loop hangs, with
    // interrupts on, LEECH_TEST_HANG ms after a boot that was not the watchdog's.
    if (!(reset_cause & (1 << WDRF)) && millis() >= LEECH_TEST_HANG)
        for (;;) {
        }
#endif
    // Outputs follow the device's state after a frame or a tick, the only things that change it.
    bool changed = false;
    while (Serial.available() > 0) {
        device_receive((uint8_t)Serial.read(), millis());
        changed = true;
    }
    if (ticks_pending) {
        // Ticks that came while a previous one ran are not dropped: the control step covers
        // them all (the ramp and the I and D terms use the true elapsed time), up to MAX_TICKS.
        uint8_t ticks;
        int32_t counts[3];
        ATOMIC_BLOCK(ATOMIC_RESTORESTATE) {
            ticks = ticks_pending;
            ticks_pending = 0;
            counts[0] = encoder_counts[0];
            counts[1] = encoder_counts[1];
            counts[2] = encoder_counts[2];
        }
        adc_poll();
        device_tick(counts, vacuum_kpa_x10, millis(), ticks < MAX_TICKS ? ticks : MAX_TICKS);
        changed = true;
    }
    if (changed) apply_outputs();
    flush_reports();

    // Sleep until an interrupt unless work is waiting. `sei` delays interrupts by one
    // instruction, so no wake-up is lost between the test and `sleep`.
    set_sleep_mode(SLEEP_MODE_IDLE);
    cli();
    bool idle = !ticks_pending && Serial.available() == 0 &&
                (dev.out.count == 0 || Serial.availableForWrite() == 0);
    if (idle) {
        sleep_enable();
        sei();
        sleep_cpu();
        sleep_disable();
    }
    sei();
}
