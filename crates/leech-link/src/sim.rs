//! The simulated controller: a LEeCH robot's firmware and its hardware as
//! pure logic with an explicit clock, no I/O.
//!
//! Bytes from the host go in with [`Sim::receive`], bytes for the host come
//! out with [`Sim::take_output`], and [`Sim::step`] advances the clock. The
//! device follows `docs/protocol.md`: it sends a `Hello` (seq 0) when made,
//! answers every command once (retries from memory), sends telemetry at the
//! configured period, stops the motors and keeps the pumps when the link is
//! lost for 500 ms, refuses to let go of the last holding cup, and latches
//! faults until cleared.
//!
//! Rules of the model (units in names: `_s` seconds, `_mm` millimetres,
//! `_um` micrometres, `_kpa` kilopascals of vacuum, `_permille` of full
//! duty):
//!
//! * **Clock.** Time advances in control ticks of
//!   [`SimConfig::control_period_s`] (1 ms); frames are handled at the tick
//!   they arrive in, then the controller, the motors and the pumps run.
//! * **Drive.** Each tube is pushed by a Pololu 75:1 micro metal gearmotor
//!   with a 12 CPR quadrature encoder on the motor shaft: 900 counts per
//!   output revolution. The output drives a roller that moves
//!   [`SimConfig::mm_per_rev`] = 20 mm of tube per revolution (a 6.4 mm
//!   roller), so 45 counts per mm. Counts are the floor of travel times
//!   counts per mm (quantized, as an encoder is).
//! * **Motor.** First order: the tube's speed tends to
//!   `duty / 1000 * free_speed_mm_s` with time constant
//!   [`SimConfig::motor_tau_s`] (20 ms); a stalled motor does not turn.
//! * **Position loop** (the firmware's, every tick): the setpoint moves to
//!   the target at no more than the configured `max_speed_um_s`, itself
//!   capped at [`SimConfig::max_tube_speed_mm_s`] (20 mm/s, the paper's);
//!   `duty = kp e + ki I + kd de/dt` clamped to the configured duty; the
//!   integral is bounded so its term alone stays within the duty limit, and
//!   it does not grow while the output is saturated in the same direction
//!   (anti-windup).
//! * **Pumps.** Vacuum tends to [`SimConfig::max_vacuum_kpa`] with time
//!   constant [`SimConfig::vacuum_tau_s`] (0.3 s) while the pump runs and
//!   the cup is sealed ([`Cups`]), and to 0 otherwise; a cup holds by
//!   [`holds`] (attach and detach thresholds from `ConfigureCups`).
//! * **Injected faults** ([`Faults`]) act on the byte streams (drop,
//!   corrupt, delay, cut) and on the hardware (a leaking cup, a stalled
//!   motor); the device detects the hardware ones as the spec says.

use std::collections::VecDeque;

use leech_protocol::frame::{self, Decoder, MAX_FRAME};
use leech_protocol::link::{
    from_a_host, holds, last_cup_allows, CupState, LinkCounters, LinkWatch, Responder, LIMIT_MARGIN_UM,
    MIN_TELEMETRY_PERIOD_MS,
};
use leech_protocol::message::{
    AckStatus, Capabilities, Command, Cup, CupConfig, CupSet, DeviceKind, Faults as FaultBits, FirmwareVersion, Hello,
    Refusal, Report, Telemetry, Tube, TubeConfig, TubeSet, Version, NO_SENSOR, PROTOCOL_VERSION,
};
use serde::{Deserialize, Serialize};

/// Stall test of the spec (9.3): a duty at least this large...
const STALL_DUTY_PERMILLE: i32 = 300;
/// ...for this many windows of [`STALL_WINDOW_MS`] without a count changing.
const STALL_WINDOWS: u32 = 5;
/// One stall-test window, ms.
const STALL_WINDOW_MS: u64 = 100;

/// Whether a cup's face is flush on a surface, so that its pump can build
/// vacuum. The caller's model of the robot's statics plugs in here.
pub trait Cups: Send {
    /// Whether `cup` is sealed when the tubes are `lengths_m` long (metres,
    /// L1, L2, L3).
    fn sealed(&self, cup: Cup, lengths_m: [f64; 3]) -> bool;

    /// Called every control tick before [`Cups::sealed`], with the tube
    /// lengths (m, L1, L2, L3), the pumps running and the cups holding (rear,
    /// front): a model whose body moves with its holds learns them here. The
    /// default ignores them.
    fn observe(&mut self, _lengths_m: [f64; 3], _pumps: [bool; 2], _holding: [bool; 2]) {}
}

/// Every cup always sealed: a robot on a flat surface.
#[derive(Clone, Copy, Debug, Default)]
pub struct AlwaysSealed;

impl Cups for AlwaysSealed {
    fn sealed(&self, _cup: Cup, _lengths_m: [f64; 3]) -> bool {
        true
    }
}

/// Faults injected into the simulated device: on its serial line (each way)
/// and on its hardware.
#[derive(Clone, Copy, Debug, PartialEq, Serialize, Deserialize)]
pub struct Faults {
    /// Probability that a byte is lost, each way (0..=1).
    pub drop_rate: f64,
    /// Probability that a byte arrives with a random change, each way (0..=1).
    pub corrupt_rate: f64,
    /// Delay added to every byte, each way, s.
    pub delay_s: f64,
    /// The line is cut: no byte is delivered either way.
    pub cut: bool,
    /// Per cup (rear, front): it leaks and can build no vacuum.
    pub vacuum_loss: [bool; 2],
    /// Per tube (L1, L2, L3): its motor is blocked and does not turn.
    pub stalled: [bool; 3],
    /// Seed of the byte faults' random numbers.
    pub seed: u64,
    /// Every `Fault` report is lost on the line (the faults still latch and
    /// show in `Telemetry.faults`): what a host must survive (spec 9.4).
    #[serde(default)]
    pub lose_fault_reports: bool,
}

impl Default for Faults {
    fn default() -> Self {
        Faults {
            drop_rate: 0.0,
            corrupt_rate: 0.0,
            delay_s: 0.0,
            cut: false,
            vacuum_loss: [false; 2],
            stalled: [false; 3],
            seed: 0x2545_f491_4f6c_dd1d,
            lose_fault_reports: false,
        }
    }
}

/// The simulated robot's hardware and identity.
#[derive(Clone, Copy, Debug, PartialEq)]
pub struct SimConfig {
    /// What the device says in its `Hello` (the protocol version included,
    /// so that a mismatch can be simulated).
    pub hello: Hello,
    /// Encoder counts per output revolution (12 CPR x 75:1 = 900).
    pub counts_per_rev: f64,
    /// Tube travel per output revolution, mm.
    pub mm_per_rev: f64,
    /// Tube speed at full duty without load, mm/s (about 400 rpm at 6 V).
    pub free_speed_mm_s: f64,
    /// The motor's mechanical time constant, s.
    pub motor_tau_s: f64,
    /// The fastest a setpoint may move whatever the configuration, mm/s.
    pub max_tube_speed_mm_s: f64,
    /// The tubes' lengths at power-up (counts 0), um.
    pub initial_lengths_um: [i32; 3],
    /// The vacuum a running pump reaches on a sealed cup, kPa.
    pub max_vacuum_kpa: f64,
    /// The vacuum's time constant, s.
    pub vacuum_tau_s: f64,
    /// The firmware's control period, s.
    pub control_period_s: f64,
}

impl Default for SimConfig {
    fn default() -> Self {
        SimConfig {
            hello: Hello {
                protocol: PROTOCOL_VERSION,
                firmware: FirmwareVersion { major: 0, minor: 1, patch: 0 },
                kind: DeviceKind::SIMULATOR,
                capabilities: Capabilities(Capabilities::REAR_VACUUM_SENSOR.0 | Capabilities::FRONT_VACUUM_SENSOR.0),
            },
            counts_per_rev: 900.0,
            mm_per_rev: 20.0,
            free_speed_mm_s: 400.0 / 60.0 * 20.0,
            motor_tau_s: 0.020,
            max_tube_speed_mm_s: 20.0,
            initial_lengths_um: [200_000; 3],
            max_vacuum_kpa: 60.0,
            vacuum_tau_s: 0.3,
            control_period_s: 0.001,
        }
    }
}

impl SimConfig {
    /// The same device speaking another protocol version.
    pub fn with_protocol(mut self, protocol: Version) -> SimConfig {
        self.hello.protocol = protocol;
        self
    }

    /// Encoder counts per mm of tube.
    pub fn counts_per_mm(&self) -> f64 {
        self.counts_per_rev / self.mm_per_rev
    }

    /// A `ConfigureTube` that fits this hardware: its scale, the power-up
    /// length as origin, limits 50..=800 mm, 20 mm/s, and gains tuned for
    /// the default motor: kp 0.3 per mille per um, ki 0.5 per mille per
    /// (um s), kd 0.003 per mille per (um/s) (damping ratio about 0.8).
    pub fn tube_config(&self, tube: Tube) -> TubeConfig {
        let q16 = |gain: f64| (gain * 65536.0).round() as i32;
        TubeConfig {
            tube,
            reverse_motor: false,
            reverse_encoder: false,
            counts_per_mm_x1000: (self.counts_per_mm() * 1000.0).round() as u32,
            origin_um: self.initial_lengths_um[tube.index()],
            min_um: 50_000,
            max_um: 800_000,
            max_speed_um_s: (self.max_tube_speed_mm_s * 1000.0) as u32,
            max_duty_permille: 1000,
            kp_q16: q16(0.3),
            ki_q16: q16(0.5),
            kd_q16: q16(0.003),
        }
    }
}

/// A snapshot of the simulated robot, for tests and tools.
#[derive(Clone, Debug, PartialEq, Serialize, Deserialize)]
pub struct SimState {
    /// Device time since power-up, s.
    pub time_s: f64,
    /// Physical tube lengths, um.
    pub lengths_um: [f64; 3],
    /// Lengths the device measures (0 for a tube not configured), um.
    pub measured_um: [i32; 3],
    /// Encoder counts (direction flag applied).
    pub counts: [i32; 3],
    /// Tube speeds, mm/s.
    pub speeds_mm_s: [f64; 3],
    /// Motor duties, per mille (positive lengthens).
    pub duty_permille: [i16; 3],
    /// Position targets of the tubes under control, um.
    pub targets_um: [Option<i32>; 3],
    /// Tubes configured since power-up.
    pub configured: [bool; 3],
    /// Pumps running (rear, front).
    pub pumps: [bool; 2],
    /// Vacuum in each cup, kPa.
    pub vacuum_kpa: [f64; 2],
    /// Cups holding.
    pub holding: [bool; 2],
    /// Latched faults (protocol bit set).
    pub faults: u16,
    /// Telemetry period, ms (0: off).
    pub telemetry_period_ms: u16,
    /// What the device received.
    pub counters: Counters,
    /// The faults injected now.
    pub injected: Faults,
    /// Device time of the last frame from a host (the link timer's start,
    /// spec 9.1), s; `None` before the first.
    #[serde(default)]
    pub last_host_frame_s: Option<f64>,
}

/// The device's receive counters (section 10 of the spec), unwrapped.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq, Serialize, Deserialize)]
pub struct Counters {
    /// Frames whose CRC matched.
    pub rx_frames: u32,
    /// Frames dropped for a CRC mismatch.
    pub bad_crc: u32,
    /// Frames dropped for anything else.
    pub bad_frames: u32,
    /// Retries answered from memory.
    pub duplicates: u32,
}

/// A tiny xorshift64* generator: reproducible byte faults without a
/// dependency.
#[derive(Clone, Copy, Debug)]
struct XorShift(u64);

impl XorShift {
    fn new(seed: u64) -> XorShift {
        // Zero is xorshift's fixed point.
        XorShift(seed.max(1))
    }

    fn next(&mut self) -> u64 {
        self.0 ^= self.0 >> 12;
        self.0 ^= self.0 << 25;
        self.0 ^= self.0 >> 27;
        self.0.wrapping_mul(0x2545_f491_4f6c_dd1d)
    }

    /// Uniform in [0, 1).
    fn unit(&mut self) -> f64 {
        (self.next() >> 11) as f64 / (1u64 << 53) as f64
    }
}

/// One tube: motor, encoder and position loop.
#[derive(Clone, Copy, Debug, Default)]
struct TubeSim {
    config: Option<TubeConfig>,
    /// Travel since power-up, mm.
    travel_mm: f64,
    speed_mm_s: f64,
    duty_permille: i16,
    target_um: Option<i32>,
    setpoint_um: f64,
    integral_um_s: f64,
    last_error_um: f64,
    /// Outside its limits (plus margin): `LIMIT_HIT` is raised on the way out only.
    out_of_limits: bool,
    stall_windows: u32,
    window_count: i32,
    window_min_duty: i32,
}

/// One cup: pump and vacuum.
#[derive(Clone, Copy, Debug, Default)]
struct CupSim {
    pump_on: bool,
    pump_since_us: u64,
    vacuum_kpa: f64,
    holding: bool,
}

/// The simulated controller and its robot.
pub struct Sim {
    config: SimConfig,
    cups_model: Box<dyn Cups>,
    faults: Faults,
    rng: XorShift,
    now_us: u64,
    next_tick_us: u64,
    tick: u64,
    decoder: Decoder,
    responder: Responder,
    watch: LinkWatch,
    /// Bytes from the host, with the time they reach the device, us.
    input: VecDeque<(u64, u8)>,
    /// Bytes for the host, with the time they leave the device, us.
    output: VecDeque<(u64, u8)>,
    tubes: [TubeSim; 3],
    cups: [CupSim; 2],
    cup_config: CupConfig,
    latched: FaultBits,
    telemetry_period_ms: u16,
    next_telemetry_ms: u64,
    /// When the last frame from a host arrived, us.
    last_host_frame_us: Option<u64>,
}

impl Sim {
    /// A device just powered up, on a flat surface; its `Hello` (seq 0) is
    /// already waiting in the output.
    pub fn new(config: SimConfig) -> Sim {
        Sim::with_cups(config, Box::new(AlwaysSealed))
    }

    /// A device whose cups seal as `cups` says.
    pub fn with_cups(config: SimConfig, cups: Box<dyn Cups>) -> Sim {
        let faults = Faults::default();
        let responder = Responder::new(config.hello);
        let mut sim = Sim {
            config,
            cups_model: cups,
            faults,
            rng: XorShift::new(faults.seed),
            now_us: 0,
            next_tick_us: 0,
            tick: 0,
            decoder: Decoder::new(),
            responder,
            watch: LinkWatch::new(),
            input: VecDeque::new(),
            output: VecDeque::new(),
            tubes: [TubeSim::default(); 3],
            cups: [CupSim::default(); 2],
            cup_config: CupConfig::default(),
            latched: FaultBits::default(),
            telemetry_period_ms: 0,
            next_telemetry_ms: 0,
            last_host_frame_us: None,
        };
        sim.send(&responder.boot_hello());
        sim
    }

    /// The controller resets (a watchdog, a glitch, a port opened with
    /// auto-reset), the robot stays where it is: the device starts over as
    /// at power-up (nothing configured, pumps off, telemetry off, counts 0,
    /// clock 0, its `Hello` sent) with the tubes at their lengths now, which
    /// become the configuration's power-up lengths. Bytes on the line are
    /// lost; the injected faults and the cups model stay.
    pub fn reset(&mut self) {
        let mut config = self.config;
        for (i, length) in config.initial_lengths_um.iter_mut().enumerate() {
            // Within half a micrometre, far below one count (22 um).
            *length = self.physical_length_um(i).round().clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32;
        }
        let cups = std::mem::replace(&mut self.cups_model, Box::new(AlwaysSealed));
        let (faults, rng) = (self.faults, self.rng);
        *self = Sim::with_cups(config, cups);
        (self.faults, self.rng) = (faults, rng);
    }

    /// Its configuration.
    pub fn config(&self) -> &SimConfig {
        &self.config
    }

    /// The faults injected now.
    pub fn faults(&self) -> Faults {
        self.faults
    }

    /// Injects `faults` from now on (a new seed restarts the random numbers).
    pub fn set_faults(&mut self, faults: Faults) {
        if faults.seed != self.faults.seed {
            self.rng = XorShift::new(faults.seed);
        }
        self.faults = faults;
    }

    /// Bytes from the host arrive now (subject to the injected line faults).
    pub fn receive(&mut self, bytes: &[u8]) {
        let due = self.now_us + self.delay_us();
        for &byte in bytes {
            if let Some(byte) = self.line(byte) {
                self.input.push_back((due, byte));
            }
        }
    }

    /// The bytes for the host that have left the device by now, appended to
    /// `out` (subject to the injected line faults).
    pub fn take_output(&mut self, out: &mut Vec<u8>) {
        let delay = self.delay_us();
        while let Some(&(sent, byte)) = self.output.front() {
            if sent + delay > self.now_us {
                break;
            }
            self.output.pop_front();
            if let Some(byte) = self.line(byte) {
                out.push(byte);
            }
        }
    }

    /// Advances the clock by `dt_s` seconds (negative or NaN counts as 0),
    /// running every control tick on the way. Bytes already due are handled
    /// even for `dt_s = 0`.
    pub fn step(&mut self, dt_s: f64) {
        let dt_us = if dt_s > 0.0 { (dt_s * 1e6).round() as u64 } else { 0 };
        let end = self.now_us.saturating_add(dt_us);
        while self.next_tick_us <= end {
            self.now_us = self.next_tick_us;
            self.handle_input();
            self.control_tick();
            self.tick += 1;
            self.next_tick_us = self.tick * self.period_us();
        }
        self.now_us = end;
        self.handle_input();
    }

    /// A snapshot of the robot and the device.
    pub fn state(&self) -> SimState {
        let counters = self.counters();
        SimState {
            time_s: self.now_us as f64 * 1e-6,
            lengths_um: std::array::from_fn(|i| self.physical_length_um(i)),
            measured_um: std::array::from_fn(|i| self.measured_um(i).unwrap_or(0)),
            counts: std::array::from_fn(|i| self.counts(i)),
            speeds_mm_s: self.tubes.map(|t| t.speed_mm_s),
            duty_permille: self.tubes.map(|t| t.duty_permille),
            targets_um: self.tubes.map(|t| t.target_um),
            configured: self.tubes.map(|t| t.config.is_some()),
            pumps: self.cups.map(|c| c.pump_on),
            vacuum_kpa: self.cups.map(|c| c.vacuum_kpa),
            holding: self.cups.map(|c| c.holding),
            faults: self.latched.0,
            telemetry_period_ms: self.telemetry_period_ms,
            counters,
            injected: self.faults,
            last_host_frame_s: self.last_host_frame_us.map(|us| us as f64 * 1e-6),
        }
    }

    fn counters(&self) -> Counters {
        let frames = self.decoder.counters();
        Counters {
            rx_frames: frames.frames,
            bad_crc: frames.bad_crc,
            bad_frames: frames.bad_frames.wrapping_add(self.responder.dropped()),
            duplicates: self.responder.duplicates(),
        }
    }

    fn period_us(&self) -> u64 {
        ((self.config.control_period_s * 1e6).round() as u64).max(1)
    }

    fn delay_us(&self) -> u64 {
        if self.faults.delay_s > 0.0 {
            (self.faults.delay_s * 1e6).round() as u64
        } else {
            0
        }
    }

    fn now_ms(&self) -> u64 {
        self.now_us / 1000
    }

    /// The device's wrapping millisecond clock.
    fn clock_ms(&self) -> u32 {
        // Truncation is the wrap of the device's u32 clock.
        self.now_ms() as u32
    }

    /// One byte through the injected line faults: lost, changed or intact.
    fn line(&mut self, byte: u8) -> Option<u8> {
        if self.faults.cut || (self.faults.drop_rate > 0.0 && self.rng.unit() < self.faults.drop_rate) {
            return None;
        }
        if self.faults.corrupt_rate > 0.0 && self.rng.unit() < self.faults.corrupt_rate {
            // A non-zero mask: the byte does change.
            let mask = (self.rng.next() % 255 + 1) as u8;
            return Some(byte ^ mask);
        }
        Some(byte)
    }

    fn send(&mut self, report: &Report) {
        let mut wire = [0u8; MAX_FRAME];
        // Every report fits a MAX_FRAME buffer.
        if let Ok(len) = report.encode_frame(&mut wire) {
            let now = self.now_us;
            self.output.extend(wire.iter().take(len).map(|&b| (now, b)));
        }
    }

    fn handle_input(&mut self) {
        while let Some(&(due, byte)) = self.input.front() {
            if due > self.now_us {
                break;
            }
            self.input.pop_front();
            let Some(Ok(message)) = self.decoder.push(byte) else { continue };
            let mut bytes = [0u8; frame::MAX_MESSAGE];
            let len = message.len();
            bytes[..len].copy_from_slice(message);
            self.handle_frame(&bytes[..len]);
        }
    }

    fn handle_frame(&mut self, message: &[u8]) {
        if from_a_host(message) {
            self.watch.frame(self.clock_ms());
            self.last_host_frame_us = Some(self.now_us);
        }
        let mut responder = self.responder;
        let answer = responder.handle(message, |command| self.execute(command));
        self.responder = responder;
        if let Some(report) = answer {
            self.send(&report);
        }
    }

    /// Carries out a new command; returns its `Ack` status.
    fn execute(&mut self, command: Command) -> AckStatus {
        match self.try_execute(command) {
            Ok(()) => AckStatus::Ok,
            Err(reason) => AckStatus::Refused(reason),
        }
    }

    fn try_execute(&mut self, command: Command) -> Result<(), Refusal> {
        match command {
            // Handled by the responder; a heartbeat only restarts the link timer.
            Command::Hello | Command::Heartbeat => {}
            Command::Stop => self.stop_motors(),
            Command::SetLengths { lengths_um } => {
                let targets = lengths_um.map(i64::from);
                self.check_motion(TubeSet::ALL, targets)?;
                for (i, target) in lengths_um.into_iter().enumerate() {
                    self.start(i, target);
                }
            }
            Command::Jog { tube, delta_um } => {
                let i = tube.index();
                let from = match self.tubes[i].target_um {
                    Some(target) => i64::from(target),
                    None => i64::from(self.measured_um(i).unwrap_or(0)),
                };
                let mut targets = [0; 3];
                targets[i] = from + i64::from(delta_um);
                self.check_motion(TubeSet::default().with(tube, true), targets)?;
                // In range, so within i32.
                self.start(i, targets[i] as i32);
            }
            Command::Pump { cup, on } => {
                last_cup_allows(cup, on, self.cup_states())?;
                let state = &mut self.cups[cup.index()];
                if on && !state.pump_on {
                    state.pump_since_us = self.now_us;
                }
                state.pump_on = on;
                if !on {
                    state.holding = false;
                }
            }
            Command::SetTelemetry { period_ms } => {
                if (1..MIN_TELEMETRY_PERIOD_MS).contains(&period_ms) {
                    return Err(Refusal::OutOfRange);
                }
                self.telemetry_period_ms = period_ms;
                self.next_telemetry_ms = self.now_ms() + u64::from(period_ms);
            }
            Command::ClearFaults { faults } => self.latched = self.latched.without(faults),
            Command::ConfigureTube(config) => {
                let tube = &mut self.tubes[config.tube.index()];
                if tube.target_um.is_some() {
                    return Err(Refusal::BadState);
                }
                config.check().map_err(|_| Refusal::OutOfRange)?;
                tube.config = Some(config);
                // Judged afresh against the new limits: a tube configured
                // while out crosses out at the next tick (spec 9.3).
                tube.out_of_limits = false;
            }
            Command::ConfigureCups(config) => {
                config.check().map_err(|_| Refusal::OutOfRange)?;
                self.cup_config = config;
            }
        }
        Ok(())
    }

    /// The refusals of a motion command, in the spec's order, for the tubes
    /// in `tubes` going to `targets_um`.
    fn check_motion(&self, tubes: TubeSet, targets_um: [i64; 3]) -> Result<(), Refusal> {
        let concerned = || Tube::ALL.into_iter().filter(|&t| tubes.contains(t));
        if concerned().any(|t| self.tubes[t.index()].config.is_none()) {
            return Err(Refusal::NotConfigured);
        }
        if self.latched.contains(FaultBits::MOTOR_STALL) {
            return Err(Refusal::Faulted);
        }
        for t in concerned() {
            let Some(config) = self.tubes[t.index()].config else { continue };
            let target = targets_um[t.index()];
            if target < i64::from(config.min_um) || target > i64::from(config.max_um) {
                return Err(Refusal::OutOfRange);
            }
        }
        Ok(())
    }

    /// Tube `i` gets a new target; entering position control, its setpoint
    /// starts at its measured length.
    fn start(&mut self, i: usize, target_um: i32) {
        let measured = f64::from(self.measured_um(i).unwrap_or(0));
        let tube = &mut self.tubes[i];
        if tube.target_um.is_none() {
            tube.setpoint_um = measured;
            tube.integral_um_s = 0.0;
            tube.last_error_um = 0.0;
        }
        tube.target_um = Some(target_um);
    }

    fn stop_motors(&mut self) {
        for tube in &mut self.tubes {
            tube.target_um = None;
            tube.duty_permille = 0;
        }
    }

    fn cup_states(&self) -> [CupState; 2] {
        self.cups.map(|c| CupState { pump_on: c.pump_on, holding: c.holding })
    }

    /// Latches `fault` and reports it: every detection is reported, latched
    /// already or not (a second link loss is news too).
    fn raise(&mut self, fault: FaultBits, detail: u8) {
        self.latched = self.latched.union(fault);
        // A fault's code is its bit number.
        let code = fault.0.trailing_zeros() as u8;
        let time_ms = self.clock_ms();
        if !self.faults.lose_fault_reports {
            self.send(&Report::Fault { time_ms, code, detail });
        }
    }

    fn physical_length_um(&self, i: usize) -> f64 {
        f64::from(self.config.initial_lengths_um[i]) + self.tubes[i].travel_mm * 1000.0
    }

    /// The encoder's count as the device reads it (direction flag applied).
    fn counts(&self, i: usize) -> i32 {
        let raw = (self.tubes[i].travel_mm * self.config.counts_per_mm()).floor();
        let raw = raw.clamp(f64::from(i32::MIN), f64::from(i32::MAX)) as i32;
        match self.tubes[i].config {
            Some(c) if c.reverse_encoder => raw.wrapping_neg(),
            _ => raw,
        }
    }

    fn measured_um(&self, i: usize) -> Option<i32> {
        Some(self.tubes[i].config?.length_um(self.counts(i)))
    }

    fn control_tick(&mut self) {
        let dt = self.period_us() as f64 * 1e-6;
        let now_ms = self.clock_ms();
        if self.watch.expired(now_ms) {
            self.stop_motors();
            self.responder.forget();
            self.raise(FaultBits::LINK_LOST, 0);
        }
        for i in 0..3 {
            self.position_loop(i, dt);
            self.check_tube(i);
        }
        self.move_motors(dt);
        self.run_pumps(dt);
        self.telemetry();
    }

    /// The firmware's position controller for tube `i`.
    fn position_loop(&mut self, i: usize, dt: f64) {
        let measured = f64::from(self.measured_um(i).unwrap_or(0));
        let cap_um_s = self.config.max_tube_speed_mm_s * 1000.0;
        let tube = &mut self.tubes[i];
        let (Some(target), Some(config)) = (tube.target_um, tube.config) else {
            tube.duty_permille = 0;
            return;
        };
        let max_step = (config.max_speed_um_s as f64).min(cap_um_s) * dt;
        let to_go = f64::from(target) - tube.setpoint_um;
        tube.setpoint_um += to_go.clamp(-max_step, max_step);

        let gain = |q16: i32| f64::from(q16) / 65536.0;
        let (kp, ki, kd) = (gain(config.kp_q16), gain(config.ki_q16), gain(config.kd_q16));
        let limit = f64::from(config.max_duty_permille);
        let error = tube.setpoint_um - measured;
        let derivative = (error - tube.last_error_um) / dt;
        tube.last_error_um = error;
        let unclamped = kp * error + ki * tube.integral_um_s + kd * derivative;
        // Anti-windup: integrate only when the output is not pushing
        // further into saturation, and bound the integral term alone.
        if unclamped.abs() < limit || unclamped.signum() != error.signum() {
            tube.integral_um_s += error * dt;
            if ki > 0.0 {
                let bound = limit / ki;
                tube.integral_um_s = tube.integral_um_s.clamp(-bound, bound);
            }
        }
        let duty = (kp * error + ki * tube.integral_um_s + kd * derivative).clamp(-limit, limit);
        tube.duty_permille = duty.round() as i16;
    }

    /// Limit and stall detection for tube `i` (section 9.3).
    fn check_tube(&mut self, i: usize) {
        let count = self.counts(i);
        let measured = self.measured_um(i);
        let window_end = self.now_ms().is_multiple_of(STALL_WINDOW_MS);
        let tube = &mut self.tubes[i];
        let detail = i as u8;
        let mut limit_hit = false;
        if let (Some(config), Some(length)) = (tube.config, measured) {
            let out = length < config.min_um.saturating_sub(LIMIT_MARGIN_UM)
                || length > config.max_um.saturating_add(LIMIT_MARGIN_UM);
            limit_hit = out && !tube.out_of_limits;
            tube.out_of_limits = out;
        }
        tube.window_min_duty = tube.window_min_duty.min(i32::from(tube.duty_permille).abs());
        let mut stalled = false;
        if window_end {
            let hard = tube.window_min_duty >= STALL_DUTY_PERMILLE;
            let still = count.wrapping_sub(tube.window_count).abs() < 1;
            tube.stall_windows = if hard && still { tube.stall_windows + 1 } else { 0 };
            stalled = tube.stall_windows >= STALL_WINDOWS;
            tube.window_count = count;
            tube.window_min_duty = i32::MAX;
        }
        if limit_hit {
            self.stop_motors();
            self.raise(FaultBits::LIMIT_HIT, detail);
        }
        if stalled {
            self.tubes[i].stall_windows = 0;
            self.stop_motors();
            self.raise(FaultBits::MOTOR_STALL, detail);
        }
    }

    /// The motors' first-order response over `dt` seconds.
    fn move_motors(&mut self, dt: f64) {
        let decay = (-dt / self.config.motor_tau_s).exp();
        for (i, tube) in self.tubes.iter_mut().enumerate() {
            let mut duty = f64::from(tube.duty_permille);
            if tube.config.is_some_and(|c| c.reverse_motor) {
                duty = -duty;
            }
            let free = duty / 1000.0 * self.config.free_speed_mm_s;
            tube.speed_mm_s = if self.faults.stalled[i] { 0.0 } else { free + (tube.speed_mm_s - free) * decay };
            tube.travel_mm += tube.speed_mm_s * dt;
        }
    }

    /// Vacuum, holding and `VACUUM_LOST` over `dt` seconds.
    fn run_pumps(&mut self, dt: f64) {
        let lengths_m: [f64; 3] = std::array::from_fn(|i| self.physical_length_um(i) * 1e-6);
        let decay = (-dt / self.config.vacuum_tau_s).exp();
        self.cups_model.observe(lengths_m, self.cups.map(|c| c.pump_on), self.cups.map(|c| c.holding));
        for cup in Cup::BOTH {
            let i = cup.index();
            let sealed = self.cups_model.sealed(cup, lengths_m);
            let state = self.cups[i];
            let goal =
                if state.pump_on && sealed && !self.faults.vacuum_loss[i] { self.config.max_vacuum_kpa } else { 0.0 };
            let vacuum = goal + (state.vacuum_kpa - goal) * decay;
            let pump_on_ms = (self.now_us.saturating_sub(state.pump_since_us) / 1000) as u32;
            let holding = holds(state.holding, state.pump_on, self.reading(cup, vacuum), pump_on_ms, &self.cup_config);
            self.cups[i].vacuum_kpa = vacuum;
            self.cups[i].holding = holding;
            if state.holding && !holding && state.pump_on {
                self.stop_motors();
                self.raise(FaultBits::VACUUM_LOST, i as u8);
            }
        }
    }

    /// What the cup's sensor reads, 0.1 kPa, or [`NO_SENSOR`].
    fn reading(&self, cup: Cup, vacuum_kpa: f64) -> u16 {
        let sensor = match cup {
            Cup::Rear => Capabilities::REAR_VACUUM_SENSOR,
            Cup::Front => Capabilities::FRONT_VACUUM_SENSOR,
        };
        if self.config.hello.capabilities.contains(sensor) {
            (vacuum_kpa * 10.0).round().clamp(0.0, f64::from(NO_SENSOR - 1)) as u16
        } else {
            NO_SENSOR
        }
    }

    fn telemetry(&mut self) {
        if self.telemetry_period_ms == 0 || self.now_ms() < self.next_telemetry_ms {
            return;
        }
        self.next_telemetry_ms += u64::from(self.telemetry_period_ms);
        let set = |bits: [bool; 3]| bits.iter().enumerate().fold(0u8, |acc, (i, &b)| acc | (u8::from(b) << i));
        let report = Report::Telemetry(Telemetry {
            time_ms: self.clock_ms(),
            counts: std::array::from_fn(|i| self.counts(i)),
            lengths_um: std::array::from_fn(|i| self.measured_um(i).unwrap_or(0)),
            duty_permille: self.tubes.map(|t| t.duty_permille),
            vacuum_kpa_x10: [Cup::Rear, Cup::Front].map(|c| self.reading(c, self.cups[c.index()].vacuum_kpa)),
            faults: self.latched,
            counters: LinkCounters::collect(self.decoder.counters(), &self.responder),
            pumps: CupSet(set([self.cups[0].pump_on, self.cups[1].pump_on, false])),
            holding: CupSet(set([self.cups[0].holding, self.cups[1].holding, false])),
            active: TubeSet(set(self.tubes.map(|t| t.target_um.is_some()))),
            configured: TubeSet(set(self.tubes.map(|t| t.config.is_some()))),
        });
        self.send(&report);
    }
}
