/*
 * leech-simavr: runs the leech controller firmware (an ATmega2560 ELF) on simavr's
 * core with a simulated LEeCH robot around it, in real time.
 *
 *   leech-simavr FIRMWARE.elf [--state-every-ms N] [--unthrottled] [--profile]
 *
 * The chip's UART0 is bridged to a pseudo-terminal whose name is the first stdout
 * line; then one JSON state line per N ms of simulated time. Commands on stdin.
 * The interface, pin map and robot are fixed by the firmware/harness contract
 * (see README.md next to this file).
 *
 * The model, updated every TICK_US = 100 us of simulated time (dt):
 *
 *   Motor i (i = 0..2 for tubes L1..L3), tube speed v [mm/s], tube length L [mm]:
 *     dv/dt = (u * V_FREE - v) / tau          V_FREE = 133.33 mm/s at full duty
 *     dL/dt = v
 *   with the driver state from IN1/IN2 and the PWM duty d in [0, 1]:
 *     IN1=H IN2=L  u = +d, tau = 20 ms       (forward, lengthens the tube)
 *     IN1=L IN2=H  u = -d, tau = 20 ms
 *     IN1=H IN2=H  u = 0,  tau = 5 ms        (short brake)
 *     IN1=L IN2=L  u = 0,  tau = 20 ms       (coast)
 *   A stalled motor has v = 0. u is constant over a tick, so both equations are
 *   integrated exactly:
 *     v(t+dt) = u V + (v - u V) e^(-dt/tau)
 *     L(t+dt) = L + u V dt + (v - u V) tau (1 - e^(-dt/tau))
 *   Encoder: 45 counts per mm of tube (900 counts per output revolution, 20 mm of
 *   tube per revolution), count = floor(45 * (L - 200 mm)); every count is one edge
 *   of the quadrature pair (A,B) = 00 -> 10 -> 11 -> 01 -> 00 forward.
 *
 *   Cup j (0 = rear, 1 = front), vacuum p [kPa]:
 *     dp/dt = (P_TARGET - p) / tau_p
 *     pump on and cup sealed:  P_TARGET = 60 kPa, tau_p = 0.3 s
 *     otherwise:               P_TARGET = 0,      tau_p = 0.1 s
 *   Sensor (MPXV6115V-like, ratiometric to 5 V): V_out [mV] = 200 + 4500 * p / 115.
 *
 * Real time: simulated time (cycles / 16 MHz) is compared with the wall clock every
 * SERVICE_TICKS ticks; when the chip is ahead the process waits in ppoll() on stdin
 * and the pty, so waiting and I/O are the same thing. The ticks are simavr cycle
 * timers, so they also bound how far simavr fast-forwards a sleeping chip.
 *
 * The UART bridge is our own rather than simavr's uart_pty part: uart_pty prints
 * to stdout (which is our protocol channel), creates a fixed-name symlink in the
 * temporary directory, runs its own thread, and feeds the chip as fast as simavr's
 * UART fifo accepts. Here bytes go to the chip one per byte time of 115200 8N1,
 * like a real line, and wait while the chip does not read them (none is lost).
 */
#define _GNU_SOURCE
#include <errno.h>
#include <fcntl.h>
#include <math.h>
#include <poll.h>
#include <pty.h>
#include <signal.h>
#include <stdarg.h>
#include <stdbool.h>
#include <stdint.h>
#include <stdio.h>
#include <stdlib.h>
#include <string.h>
#include <sys/stat.h>
#include <termios.h>
#include <time.h>
#include <unistd.h>

#include <avr_adc.h>
#include <avr_extint.h>
#include <avr_ioport.h>
#include <avr_uart.h>
#include <sim_avr.h>
#include <sim_elf.h>
#include <sim_irq.h>

/* The accessors of the UART's receive fifo (avr_uart.h declares its type). */
DEFINE_FIFO(uint16_t, uart_fifo);

#define F_CPU 16000000UL
#define TICK_US 100
#define TICK_CYCLES (F_CPU / 1000000UL * TICK_US)
/* I/O and the real-time check every 1 ms of simulated time: 115200 baud is about
 * 11.5 bytes per ms, well inside the pty's buffers. */
#define SERVICE_TICKS 10
/* Byte time of 115200 8N1 (10 bits), in cycles. */
#define UART_BYTE_CYCLES (F_CPU * 10UL / 115200UL)
/* After the process was descheduled (loaded CI machine), the chip catches up at
 * most this much; older lag is forgotten so it never races through seconds of
 * firmware time at once. */
#define MAX_LAG_NS 50000000LL

/* Robot constants (contract: "The robot the harness simulates"). */
#define N_MOTORS 3
#define N_CUPS 2
#define V_FREE_MM_S 133.33
#define TAU_DRIVE_S 0.020
#define TAU_BRAKE_S 0.005
#define COUNTS_PER_MM 45.0
#define L0_MM 200.0
#define P_PUMP_KPA 60.0
#define TAU_PUMP_ON_S 0.3
#define TAU_PUMP_OFF_S 0.1

/* ATmega2560 data-space addresses of the registers the harness reads (datasheet
 * "Register Summary"; I/O registers are at I/O address + 0x20). */
#define REG_DDRA 0x21
#define REG_PORTA 0x22
#define REG_DDRE 0x2D
#define REG_PORTE 0x2E
#define REG_TCCR3A 0x90
#define REG_OCR3AL 0x98
#define REG_TCCR4A 0xA0
#define REG_OCR4AL 0xA8
#define REG_OCR4BL 0xAA
#define REG_UCSR0B 0xC1
#define BIT_RXEN0 4
#define REG_DDRH 0x101
#define REG_PORTH 0x102

/* Where each motor's signals are (contract pin map). */
struct motor_pins {
	uint16_t tccra, ocr;    /* timer control A and the OCR low byte */
	uint8_t com_shift;      /* position of the COMnx1:0 bits in TCCRnA */
	uint16_t pwm_port, pwm_ddr;
	uint8_t pwm_bit;
	uint8_t in1_bit, in2_bit; /* on PORTA */
	char enc_port;           /* 'D' or 'E' */
	uint8_t enc_a_bit, enc_b_bit;
};

static const struct motor_pins MOTOR_PINS[N_MOTORS] = {
	{ REG_TCCR3A, REG_OCR3AL, 6, REG_PORTE, REG_DDRE, 3, 0, 1, 'E', 4, 5 },
	{ REG_TCCR4A, REG_OCR4AL, 6, REG_PORTH, REG_DDRH, 3, 2, 3, 'D', 3, 2 },
	{ REG_TCCR4A, REG_OCR4BL, 4, REG_PORTH, REG_DDRH, 4, 4, 5, 'D', 1, 0 },
};
static const uint8_t PUMP_BIT[N_CUPS] = { 5, 6 }; /* on PORTH */

enum drive { COAST, FORWARD, BACKWARD, BRAKE };

struct motor {
	enum drive drive;
	double duty;          /* PWM duty, 0..1 */
	double speed_mm_s;
	double length_mm;
	int64_t count;        /* the encoder count the chip has been shown */
	bool stalled;
	avr_irq_t *irq_a, *irq_b;
};

struct cup {
	bool pump_on, sealed;
	double vacuum_kpa;
	uint32_t adc_mv;      /* last value sent to the ADC, to skip repeats */
	avr_irq_t *adc_irq;
};

/* Bytes in flight between the pty and the chip. */
#define RING_SIZE 65536
struct ring {
	uint8_t buf[RING_SIZE];
	size_t head, len;
};

static struct {
	avr_t *avr;
	struct motor motor[N_MOTORS];
	struct cup cup[N_CUPS];
	/* Pull-up values of the encoder inputs per port: simavr re-sends a port's
	 * input pins on every PORT write, so an input with the firmware's pull-up on
	 * would jump to 1 and fake an encoder edge unless the port knows the level
	 * the encoder drives. */
	uint8_t enc_mask_d, enc_mask_e, enc_level_d, enc_level_e;

	int pty_master, pty_slave;
	struct ring to_chip, to_host;
	avr_uart_t *uart;
	avr_irq_t *uart_in;

	uint64_t ticks;
	unsigned state_every_ticks;
	bool service_due, throttled, chip_reset;

	/* Real-time bookkeeping (CLOCK_MONOTONIC ns, simulated ns). */
	int64_t wall_origin;
	int64_t rate_wall, rate_sim; /* start of the current sim_rate window */
	bool rate_window_done;
	double sim_rate;

	char cmd[256];
	size_t cmd_len;
	bool stdin_open;

	/* --profile, over the window since the last state line (cycles): a control
	 * tick runs from the entry of the firmware's Timer5 compare interrupt to the
	 * chip's next sleep; the rest of the time not asleep is also busy. */
	bool profile, in_tick;
	avr_cycle_count_t tick_start, tick_sum, tick_max, asleep, window_start;
	unsigned long tick_count;
} S;

/* The firmware's control tick (Timer5 compare A, leech.ino). */
#define TICK_VECTOR 47

static volatile sig_atomic_t g_stop_signal;

static void on_signal(int sig) { g_stop_signal = sig; }

static int64_t wall_ns(void)
{
	struct timespec ts;
	clock_gettime(CLOCK_MONOTONIC, &ts);
	return (int64_t)ts.tv_sec * 1000000000LL + ts.tv_nsec;
}

static int64_t sim_ns(void)
{
	/* 16 MHz: 62.5 ns per cycle. */
	return (int64_t)(S.avr->cycle * 125 / 2);
}

static bool bit(uint16_t reg, uint8_t b) { return (S.avr->data[reg] >> b) & 1; }

/* simavr's logger writes LOG_OUTPUT to stdout, which carries our protocol. Its
 * warnings are dropped: 1.6 warns on every OCR write in the PWM modes it does not
 * model (8-bit phase correct on Timer3/4), and the harness reads OCR itself. */
static void logger(avr_t *avr, const int level, const char *fmt, va_list ap)
{
	if (level > LOG_ERROR || (avr && level > avr->log))
		return;
	vfprintf(stderr, fmt, ap);
}

/* The throttle replaces simavr's own sleep (a usleep per sleep period), which
 * would wait a second time for what ppoll already waits for. */
static void no_sleep(avr_t *avr, avr_cycle_count_t how_long)
{
	if (!S.profile)
		return;
	/* simavr advances a sleeping chip by how_long + 1 cycles per call. */
	S.asleep += how_long + 1;
	if (S.in_tick) {
		avr_cycle_count_t took = avr->cycle - S.tick_start;
		S.tick_sum += took;
		if (took > S.tick_max)
			S.tick_max = took;
		S.tick_count++;
		S.in_tick = false;
	}
}

static void on_tick_interrupt(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	(void)param;
	/* A tick that starts while the previous one still runs (an overrun) is
	 * counted as part of it. */
	if (value && !S.in_tick) {
		S.in_tick = true;
		S.tick_start = S.avr->cycle;
	}
}

/* simavr's reset (the watchdog's) drops every cycle timer, the tick among them,
 * and re-arms the peripherals' defaults; the main loop connects the chip again
 * once the reset is complete (this hook runs in the middle of it). */
static void (*core_reset)(avr_t *avr);

static void on_reset(avr_t *avr)
{
	if (core_reset)
		core_reset(avr);
	S.chip_reset = true;
}

/* ---- Ring buffers ---- */

static size_t ring_free(const struct ring *r) { return RING_SIZE - r->len; }

static void ring_push(struct ring *r, const uint8_t *p, size_t n)
{
	for (size_t i = 0; i < n; i++)
		r->buf[(r->head + r->len + i) % RING_SIZE] = p[i];
	r->len += n;
}

/* The contiguous readable part. */
static size_t ring_peek(const struct ring *r, const uint8_t **p)
{
	*p = r->buf + r->head;
	size_t n = RING_SIZE - r->head;
	return r->len < n ? r->len : n;
}

static void ring_drop(struct ring *r, size_t n)
{
	r->head = (r->head + n) % RING_SIZE;
	r->len -= n;
}

/* ---- The chip's side of the robot ---- */

/* Duty and drive state of one motor from the timer and port registers. */
static void read_driver(int i)
{
	const struct motor_pins *p = &MOTOR_PINS[i];
	struct motor *m = &S.motor[i];
	double duty = 0;
	if (bit(p->pwm_ddr, p->pwm_bit)) {
		uint8_t com = (S.avr->data[p->tccra] >> p->com_shift) & 3;
		uint8_t ocr = S.avr->data[p->ocr];
		if (com == 2) /* non-inverting PWM, what analogWrite sets */
			duty = ocr / 255.0;
		else if (com == 3)
			duty = (255 - ocr) / 255.0;
		else /* compare output disconnected: the pin is a plain output */
			duty = bit(p->pwm_port, p->pwm_bit);
	}
	bool in1 = bit(REG_DDRA, p->in1_bit) && bit(REG_PORTA, p->in1_bit);
	bool in2 = bit(REG_DDRA, p->in2_bit) && bit(REG_PORTA, p->in2_bit);
	m->duty = duty;
	m->drive = in1 ? (in2 ? BRAKE : FORWARD) : (in2 ? BACKWARD : COAST);
}

static void set_external(char port, uint8_t mask, uint8_t level)
{
	avr_ioport_external_t e = { .name = port, .mask = mask, .value = level };
	avr_ioctl(S.avr, AVR_IOCTL_IOPORT_SET_EXTERNAL(port), &e);
}

/* One quadrature step of motor i in direction dir (+1 or -1). Only one of A and B
 * changes, so the firmware's pin-change ISR fires once per count. */
static void encoder_step(int i, int dir)
{
	static const uint8_t A[4] = { 0, 1, 1, 0 }, B[4] = { 0, 0, 1, 1 };
	const struct motor_pins *p = &MOTOR_PINS[i];
	struct motor *m = &S.motor[i];
	unsigned was = (unsigned)(m->count & 3);
	m->count += dir;
	unsigned q = (unsigned)(m->count & 3);
	uint8_t bits = (uint8_t)(A[q] << p->enc_a_bit | B[q] << p->enc_b_bit);
	uint8_t mask = (uint8_t)(1u << p->enc_a_bit | 1u << p->enc_b_bit);
	uint8_t *level = p->enc_port == 'D' ? &S.enc_level_d : &S.enc_level_e;
	*level = (uint8_t)((*level & ~mask) | bits);
	set_external(p->enc_port, p->enc_port == 'D' ? S.enc_mask_d : S.enc_mask_e, *level);
	if (A[q] != A[was])
		avr_raise_irq(m->irq_a, A[q]);
	else
		avr_raise_irq(m->irq_b, B[q]);
}

static void step_motor(int i, double dt)
{
	struct motor *m = &S.motor[i];
	read_driver(i);
	if (m->stalled) {
		m->speed_mm_s = 0;
	} else {
		double u = 0, tau = TAU_DRIVE_S;
		if (m->drive == FORWARD)
			u = m->duty;
		else if (m->drive == BACKWARD)
			u = -m->duty;
		else if (m->drive == BRAKE)
			tau = TAU_BRAKE_S;
		double target = u * V_FREE_MM_S, k = 1 - exp(-dt / tau);
		double dv = m->speed_mm_s - target;
		m->length_mm += target * dt + dv * tau * k;
		m->speed_mm_s = target + dv * (1 - k);
	}
	/* At most one edge per motor per tick: the fastest tube moves 6000 counts/s,
	 * 0.6 per tick, so this never falls behind, and two edges of one encoder are
	 * never raised at the same instant. */
	int64_t want = (int64_t)floor((m->length_mm - L0_MM) * COUNTS_PER_MM);
	if (want > m->count)
		encoder_step(i, +1);
	else if (want < m->count)
		encoder_step(i, -1);
}

static void step_cup(int j, double dt)
{
	struct cup *c = &S.cup[j];
	c->pump_on = bit(REG_DDRH, PUMP_BIT[j]) && bit(REG_PORTH, PUMP_BIT[j]);
	bool pumping = c->pump_on && c->sealed;
	double target = pumping ? P_PUMP_KPA : 0;
	double tau = pumping ? TAU_PUMP_ON_S : TAU_PUMP_OFF_S;
	c->vacuum_kpa = target + (c->vacuum_kpa - target) * exp(-dt / tau);
	uint32_t mv = (uint32_t)lround(200 + 4500 * c->vacuum_kpa / 115);
	if (mv != c->adc_mv) {
		c->adc_mv = mv;
		avr_raise_irq(c->adc_irq, mv);
	}
}

static void print_state(void)
{
	struct motor *m = S.motor;
	int d[N_MOTORS];
	for (int i = 0; i < N_MOTORS; i++) {
		int s = m[i].drive == FORWARD ? 1 : m[i].drive == BACKWARD ? -1 : 0;
		d[i] = s * (int)lround(m[i].duty * 1000);
	}
	char line[512];
	int len = snprintf(line, sizeof line,
	       "{\"t_ms\":%llu,\"duty_permille\":[%d,%d,%d],\"brake\":[%d,%d,%d],"
	       "\"pumps\":[%d,%d],\"lengths_um\":[%ld,%ld,%ld],\"counts\":[%lld,%lld,%lld],"
	       "\"vacuum_kpa_x10\":[%ld,%ld],\"sim_rate\":%.3f}\n",
	       (unsigned long long)(S.ticks * TICK_US / 1000), d[0], d[1], d[2],
	       m[0].drive == BRAKE, m[1].drive == BRAKE, m[2].drive == BRAKE,
	       S.cup[0].pump_on, S.cup[1].pump_on,
	       lround(m[0].length_mm * 1000), lround(m[1].length_mm * 1000),
	       lround(m[2].length_mm * 1000),
	       (long long)m[0].count, (long long)m[1].count, (long long)m[2].count,
	       lround(S.cup[0].vacuum_kpa * 10), lround(S.cup[1].vacuum_kpa * 10), S.sim_rate);
	if (S.profile && len > 2 && (size_t)len < sizeof line) {
		/* Cycles at 16 MHz: 16 per us. */
		avr_cycle_count_t window = S.avr->cycle - S.window_start;
		double mean_us = S.tick_count ? (double)S.tick_sum / S.tick_count / 16.0 : 0.0;
		len -= 2; /* over the closing brace and newline */
		len += snprintf(line + len, sizeof line - (size_t)len,
		       ",\"ticks\":%lu,\"tick_us_mean\":%.1f,\"tick_us_max\":%.1f,\"busy\":%.3f}\n",
		       S.tick_count, mean_us, (double)S.tick_max / 16.0,
		       window ? 1.0 - (double)S.asleep / (double)window : 0.0);
		S.window_start = S.avr->cycle;
		S.tick_sum = S.tick_max = S.asleep = 0;
		S.tick_count = 0;
	}
	/* One write per line (shorter than PIPE_BUF, so whole or not at all). On a
	 * pipe stdout is non-blocking: a reader that stops reading loses lines
	 * instead of freezing the chip. */
	if (write(STDOUT_FILENO, line, (size_t)len) < 0 && errno != EAGAIN && errno != EINTR) {
		/* The reader is gone: nobody is left to drive the robot. */
		g_stop_signal = SIGPIPE;
	}
}

static avr_cycle_count_t on_tick(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)avr;
	(void)param;
	const double dt = TICK_US * 1e-6;
	for (int i = 0; i < N_MOTORS; i++)
		step_motor(i, dt);
	for (int j = 0; j < N_CUPS; j++)
		step_cup(j, dt);
	S.ticks++;
	if (S.ticks % S.state_every_ticks == 0)
		print_state();
	if (S.ticks % SERVICE_TICKS == 0)
		S.service_due = true;
	return when + TICK_CYCLES;
}

/* ---- UART bridge ---- */

static void on_uart_out(avr_irq_t *irq, uint32_t value, void *param)
{
	(void)irq;
	(void)param;
	uint8_t b = (uint8_t)value;
	/* Like a real line nobody listens to: when the host does not read, bytes
	 * beyond the buffer are lost. */
	if (ring_free(&S.to_host) > 0)
		ring_push(&S.to_host, &b, 1);
}

/* One byte to the chip per byte time while there are any, and while its UART's
 * receive fifo has room: that fifo's XON signal is only raised when the firmware
 * polls the status register with the fifo empty, which an interrupt-driven
 * receiver may never do, so the fifo itself is looked at. Bytes wait for the
 * firmware to enable the receiver (simavr drops them otherwise), so a host may
 * talk as soon as it has the port name. */
static avr_cycle_count_t on_uart_byte(avr_t *avr, avr_cycle_count_t when, void *param)
{
	(void)param;
	if (S.to_chip.len == 0)
		return 0;
	if (!uart_fifo_isfull(&S.uart->input) && ((avr->data[REG_UCSR0B] >> BIT_RXEN0) & 1)) {
		const uint8_t *p;
		ring_peek(&S.to_chip, &p);
		uint8_t b = *p;
		ring_drop(&S.to_chip, 1);
		avr_raise_irq(S.uart_in, b);
	}
	return when + UART_BYTE_CYCLES;
}

static int open_pty(void)
{
	char name[128];
	if (openpty(&S.pty_master, &S.pty_slave, name, NULL, NULL) != 0) {
		perror("leech-simavr: openpty");
		return -1;
	}
	/* Raw, no echo: the link carries binary COBS frames. Our slave descriptor stays
	 * open for the whole run so the master never sees a hang-up when a client
	 * closes and reopens the port. */
	struct termios tio;
	tcgetattr(S.pty_slave, &tio);
	cfmakeraw(&tio);
	cfsetspeed(&tio, B115200);
	tcsetattr(S.pty_slave, TCSANOW, &tio);
	fcntl(S.pty_master, F_SETFL, fcntl(S.pty_master, F_GETFL) | O_NONBLOCK);
	fcntl(S.pty_master, F_SETFD, FD_CLOEXEC);
	fcntl(S.pty_slave, F_SETFD, FD_CLOEXEC);
	printf("port %s\n", name);
	fflush(stdout);
	/* Only a pipe: a terminal's open file is shared with the shell. */
	struct stat st;
	if (fstat(STDOUT_FILENO, &st) == 0 && S_ISFIFO(st.st_mode))
		fcntl(STDOUT_FILENO, F_SETFL, fcntl(STDOUT_FILENO, F_GETFL) | O_NONBLOCK);
	return 0;
}

/* ---- stdin commands ---- */

static void run_command(char *line)
{
	char verb[32];
	int arg = -1;
	int n = sscanf(line, "%31s %d", verb, &arg);
	if (n < 1)
		return;
	if (strcmp(verb, "quit") == 0) {
		S.stdin_open = false;
		g_stop_signal = -1;
		return;
	}
	bool cup_cmd = strcmp(verb, "vacuum-loss") == 0 || strcmp(verb, "seal") == 0;
	bool motor_cmd = strcmp(verb, "stall") == 0 || strcmp(verb, "free") == 0;
	int limit = cup_cmd ? N_CUPS : N_MOTORS;
	if ((!cup_cmd && !motor_cmd) || n != 2 || arg < 0 || arg >= limit) {
		fprintf(stderr, "leech-simavr: unknown command: %s\n", line);
		return;
	}
	if (cup_cmd)
		S.cup[arg].sealed = strcmp(verb, "seal") == 0;
	else
		S.motor[arg].stalled = strcmp(verb, "stall") == 0;
}

static void read_stdin(void)
{
	char buf[512];
	ssize_t n = read(STDIN_FILENO, buf, sizeof buf);
	if (n <= 0) {
		if (n == 0 || (errno != EINTR && errno != EAGAIN)) {
			S.stdin_open = false;
			g_stop_signal = -1;
		}
		return;
	}
	for (ssize_t k = 0; k < n; k++) {
		char c = buf[k];
		if (c == '\n') {
			S.cmd[S.cmd_len] = 0;
			run_command(S.cmd);
			S.cmd_len = 0;
		} else if (S.cmd_len < sizeof S.cmd - 1) {
			S.cmd[S.cmd_len++] = c;
		}
	}
}

/* ---- Service: pty and stdin I/O, real-time throttle, sim_rate ---- */

static void pump_pty(short revents)
{
	if (revents & POLLIN) {
		/* Leave what does not fit in the pty: the host's writes then block, the
		 * flow control a real serial driver gives it. */
		uint8_t buf[1024];
		size_t room = ring_free(&S.to_chip) < sizeof buf ? ring_free(&S.to_chip) : sizeof buf;
		ssize_t n = room ? read(S.pty_master, buf, room) : 0;
		if (n > 0) {
			ring_push(&S.to_chip, buf, (size_t)n);
			if (!avr_cycle_timer_status(S.avr, on_uart_byte, NULL))
				avr_cycle_timer_register(S.avr, UART_BYTE_CYCLES, on_uart_byte, NULL);
		}
	}
	if (S.to_host.len) {
		const uint8_t *p;
		size_t len = ring_peek(&S.to_host, &p);
		ssize_t n = write(S.pty_master, p, len);
		if (n > 0)
			ring_drop(&S.to_host, (size_t)n);
	}
}

/* Waits up to timeout_ns (0: just looks) for stdin or the pty, and serves them. */
static void poll_io(int64_t timeout_ns)
{
	struct pollfd fds[2] = {
		{ .fd = S.pty_master, .events = POLLIN | (S.to_host.len ? POLLOUT : 0) },
		{ .fd = S.stdin_open ? STDIN_FILENO : -1, .events = POLLIN },
	};
	struct timespec ts = { .tv_sec = timeout_ns / 1000000000LL,
		               .tv_nsec = timeout_ns % 1000000000LL };
	if (ppoll(fds, 2, &ts, NULL) <= 0)
		return;
	pump_pty(fds[0].revents);
	if (fds[1].revents)
		read_stdin();
}

static void service(void)
{
	int64_t now = wall_ns(), sim = sim_ns();
	/* sim_rate over the last whole second of wall time; during the first second,
	 * over the time since the start. */
	int64_t span = now - S.rate_wall;
	if ((span >= 1000000000LL || !S.rate_window_done) && span > 0)
		S.sim_rate = (double)(sim - S.rate_sim) / (double)span;
	if (span >= 1000000000LL) {
		S.rate_wall = now;
		S.rate_sim = sim;
		S.rate_window_done = true;
	}
	if (!S.throttled) {
		poll_io(0);
		return;
	}
	int64_t lead = sim - (now - S.wall_origin);
	if (lead < -MAX_LAG_NS)
		S.wall_origin = now - sim - MAX_LAG_NS;
	do {
		poll_io(lead > 0 ? lead : 0);
		lead = sim - (wall_ns() - S.wall_origin);
	} while (lead > 0 && !g_stop_signal);
}

/* ---- Set-up ---- */

static int usage(void)
{
	fprintf(stderr, "usage: leech-simavr FIRMWARE.elf [--state-every-ms N] [--unthrottled] [--profile]\n");
	return 2;
}

/* What the chip's reset (power-up, watchdog) undoes. The robot keeps its state. */
static void connect_chip(void)
{
	/* UART0: no console echo of the firmware's bytes (simavr prints them to
	 * stdout), no usleep when the firmware polls the status register. */
	uint32_t flags = 0;
	avr_ioctl(S.avr, AVR_IOCTL_UART_SET_FLAGS('0'), &flags);
	/* simavr (1.6) starts a poll every cycle, for as long as the pin stays low,
	 * whenever an INT pin in level mode (the reset default) is written low, and
	 * keeps raising the interrupt from it even after the firmware switched the
	 * pin to any-edge mode: the ISR would run without end while an encoder
	 * output is low. The firmware uses edge modes only, so the level polling is
	 * turned off (level mode then acts as falling edge). */
	for (uint8_t n = 0; n < 8; n++)
		avr_extint_set_strict_lvl_trig(S.avr, n, 0);
	for (int j = 0; j < N_CUPS; j++)
		avr_raise_irq(S.cup[j].adc_irq, S.cup[j].adc_mv);
	if (S.to_chip.len)
		avr_cycle_timer_register(S.avr, UART_BYTE_CYCLES, on_uart_byte, NULL);
	avr_cycle_timer_register(S.avr, TICK_CYCLES, on_tick, NULL);
}

static int connect_robot(void)
{
	for (int i = 0; i < N_MOTORS; i++) {
		const struct motor_pins *p = &MOTOR_PINS[i];
		struct motor *m = &S.motor[i];
		m->length_mm = L0_MM;
		m->irq_a = avr_io_getirq(S.avr, AVR_IOCTL_IOPORT_GETIRQ(p->enc_port), p->enc_a_bit);
		m->irq_b = avr_io_getirq(S.avr, AVR_IOCTL_IOPORT_GETIRQ(p->enc_port), p->enc_b_bit);
		uint8_t mask = (uint8_t)(1u << p->enc_a_bit | 1u << p->enc_b_bit);
		if (p->enc_port == 'D')
			S.enc_mask_d |= mask;
		else
			S.enc_mask_e |= mask;
	}
	set_external('D', S.enc_mask_d, S.enc_level_d);
	set_external('E', S.enc_mask_e, S.enc_level_e);
	for (int j = 0; j < N_CUPS; j++) {
		S.cup[j].sealed = true;
		S.cup[j].adc_irq = avr_io_getirq(S.avr, AVR_IOCTL_ADC_GETIRQ, ADC_IRQ_ADC0 + j);
		S.cup[j].adc_mv = 200; /* 0 kPa */
	}
	S.uart_in = avr_io_getirq(S.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_INPUT);
	avr_irq_register_notify(avr_io_getirq(S.avr, AVR_IOCTL_UART_GETIRQ('0'), UART_IRQ_OUTPUT),
				on_uart_out, NULL);
	/* The UART module itself, for its receive fifo (see on_uart_byte); avr_io_t
	 * is its first member. */
	for (avr_io_t *io = S.avr->io_port; io; io = io->next)
		if (io->irq_ioctl_get == AVR_IOCTL_UART_GETIRQ('0'))
			S.uart = (avr_uart_t *)io;
	if (!S.uart) {
		fprintf(stderr, "leech-simavr: simavr's atmega2560 has no UART0\n");
		return -1;
	}
	connect_chip();
	return 0;
}

int main(int argc, char **argv)
{
	const char *elf = NULL;
	unsigned every_ms = 10;
	S.throttled = true;
	for (int k = 1; k < argc; k++) {
		if (strcmp(argv[k], "--state-every-ms") == 0 && k + 1 < argc) {
			char *end;
			unsigned long v = strtoul(argv[++k], &end, 10);
			if (*end || v == 0 || v > 3600000)
				return usage();
			every_ms = (unsigned)v;
		} else if (strcmp(argv[k], "--unthrottled") == 0) {
			S.throttled = false;
		} else if (strcmp(argv[k], "--profile") == 0) {
			S.profile = true;
		} else if (argv[k][0] == '-' || elf) {
			return usage();
		} else {
			elf = argv[k];
		}
	}
	if (!elf)
		return usage();
	S.state_every_ticks = every_ms * (1000 / TICK_US);

	avr_global_logger_set(logger);
	elf_firmware_t fw;
	memset(&fw, 0, sizeof fw);
	if (elf_read_firmware(elf, &fw) != 0) {
		fprintf(stderr, "leech-simavr: cannot read firmware %s\n", elf);
		return 1;
	}
	fw.frequency = F_CPU;
	fw.vcc = fw.avcc = fw.aref = 5000; /* millivolts; the sensors are ratiometric to 5 V */
	S.avr = avr_make_mcu_by_name("atmega2560");
	if (!S.avr || avr_init(S.avr) != 0) {
		fprintf(stderr, "leech-simavr: simavr has no atmega2560\n");
		return 1;
	}
	S.avr->log = LOG_ERROR;
	avr_load_firmware(S.avr, &fw);
	S.avr->frequency = F_CPU;
	S.avr->sleep = no_sleep;
	avr_irq_register_notify(avr_get_interrupt_irq(S.avr, TICK_VECTOR) + AVR_INT_IRQ_RUNNING,
				on_tick_interrupt, NULL);
	core_reset = S.avr->reset;
	S.avr->reset = on_reset;

	struct sigaction sa;
	memset(&sa, 0, sizeof sa);
	sa.sa_handler = on_signal;
	sigaction(SIGTERM, &sa, NULL);
	sigaction(SIGINT, &sa, NULL);
	signal(SIGPIPE, SIG_IGN);

	if (connect_robot() != 0 || open_pty() != 0)
		return 1;
	S.stdin_open = true;
	S.wall_origin = S.rate_wall = wall_ns();

	int status = 0;
	while (!g_stop_signal) {
		int state = avr_run(S.avr);
		if (state == cpu_Done || state == cpu_Crashed) {
			fprintf(stderr, "leech-simavr: firmware %s at pc 0x%05x after %.3f s\n",
				state == cpu_Crashed ? "crashed" : "stopped (sleep with interrupts off)",
				S.avr->pc, sim_ns() * 1e-9);
			status = 3;
			break;
		}
		if (S.chip_reset) {
			S.chip_reset = false;
			fprintf(stderr, "leech-simavr: chip reset at %.3f s\n", sim_ns() * 1e-9);
			connect_chip();
		}
		if (S.service_due) {
			S.service_due = false;
			service();
		}
	}
	close(S.pty_master);
	close(S.pty_slave);
	avr_terminate(S.avr);
	return status;
}
