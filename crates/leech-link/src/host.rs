//! The host's driver: a LEeCH controller (a Mega, or a [`crate::pty`]
//! simulation) on a serial port, behind a typed, blocking API.
//!
//! Rules (times in ms unless named otherwise):
//!
//! * **Opening** ([`Link::open`]): the port is opened at 115200 baud, 8N1,
//!   no flow control. Opening a Mega's port resets it, and bytes sent while
//!   its bootloader runs can break the boot, so the driver sends nothing
//!   until the device's unsolicited `Hello` arrives, at most
//!   [`Options::boot_timeout`] (3000 ms); then it sends one `0x00` and a
//!   `Hello` (seq 1), retried, and checks the protocol's major version
//!   ([`LinkError::Version`] names both versions).
//! * **Commands**: one in flight. Each is sent, then sent again with the
//!   same seq every 50 ms without an answer, 6 sends at most
//!   ([`Pending`]); the answer is the `Ack` (status Ok gives [`Acked`], a
//!   refusal [`LinkError::Refused`], a decoding complaint
//!   [`LinkError::Rejected`]) or [`LinkError::NoAck`] after 300 ms. `Stop`
//!   overtakes the command in flight and every command queued before it
//!   (but other `Stop`s): each fails with [`LinkError::Overtaken`], none is
//!   sent after the `Stop`.
//! * **Heartbeat**: when nothing was sent for [`HEARTBEAT_MS`] (100 ms,
//!   well inside the device's 500 ms link timeout) a `Heartbeat` goes out.
//! * **Reading**: a background thread owns the port; it decodes every
//!   frame, routes answers to the command in flight, and hands telemetry
//!   and faults to every subscriber ([`Link::subscribe`]). Bad frames are
//!   counted, never fatal; no byte sequence makes the driver panic.
//! * **Health** ([`Link::health`]): round-trip times of the last
//!   [`LATENCY_WINDOW`] answers (first send to answer), sends, resends,
//!   give-ups, the host's receive counters, and the device's own counters
//!   from its last telemetry.
//! * **Reconnection**: when the port fails (unplugged, device gone), the
//!   command in flight and every new one fail with
//!   [`LinkError::Disconnected`]; every [`Options::reconnect_interval`] the
//!   driver opens the path again and repeats the handshake, then reports
//!   [`Event::Reconnected`].
//! * **Restoring the session**: the driver remembers the configuration the
//!   device accepted (cups, each tube, the telemetry period) and each
//!   configured tube's last measured length. After a reconnection, or an
//!   unsolicited `Hello` in mid-session ([`Event::DeviceReset`]: a Mega
//!   that reset has lost its configuration, its encoder counts and its
//!   pumps), it configures the device again before anything else is sent,
//!   then reports [`Event::Restored`]. A tube the device still has
//!   configured is left alone. A tube it lost is configured again with its
//!   origin re-zeroed, so that its length reads as the last length measured
//!   before the loss (`origin = last length - counts x 1000000 /
//!   counts_per_mm_x1000`): right when the tubes did not move meanwhile
//!   (the motors were stopped), and said in the event so that the caller
//!   can re-calibrate if they might have. A tube whose length was never
//!   measured stays unconfigured (motion is refused `NotConfigured`).
//!   Pumps and motion are never restored: a reset lets go, and what to do
//!   about it is the caller's decision.

use std::collections::VecDeque;
use std::io::{ErrorKind, Read, Write};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use leech_protocol::frame::{Decoder, MAX_FRAME};
use leech_protocol::link::{
    check_version, LinkCounters, Pending, Retry, VersionMismatch, BAUD_RATE, BOOT_TIMEOUT_MS, HEARTBEAT_MS,
};
use leech_protocol::message::{
    types, AckStatus, Command, Cup, CupConfig, DecodeError, Faults, Hello, Refusal, Report, Seq, Telemetry, Tube,
    TubeConfig, TubeSet,
};
use serialport::SerialPort;

/// How many round-trip times [`Health`] keeps.
pub const LATENCY_WINDOW: usize = 32;

/// How long the port's reads wait for a byte: the reader's poll period.
const READ_TIMEOUT: Duration = Duration::from_millis(1);

/// Slack on the wait for a command's outcome, for a busy machine.
const CALL_SLACK: Duration = Duration::from_secs(1);

/// How the driver opens and keeps the link.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Options {
    /// How long to wait for the device's unsolicited `Hello` after opening.
    pub boot_timeout: Duration,
    /// Whether to reopen the port when it fails.
    pub reconnect: bool,
    /// How often to try reopening a failed port.
    pub reconnect_interval: Duration,
}

impl Default for Options {
    fn default() -> Self {
        Options {
            boot_timeout: Duration::from_millis(u64::from(BOOT_TIMEOUT_MS)),
            reconnect: true,
            reconnect_interval: Duration::from_millis(200),
        }
    }
}

/// Why the link or a command failed.
#[derive(Debug, thiserror::Error)]
pub enum LinkError {
    /// The serial port could not be opened. Said as a value a user gave (the
    /// caller puts its flag before it): what is allowed is a serial device.
    #[error(
        "got {}, which cannot be opened as a serial port ({source}); expected a serial device (a terminal) such as /dev/ttyACM0",
        leech::files::shown(path)
    )]
    Open {
        /// The port's path.
        path: PathBuf,
        /// Why.
        source: serialport::Error,
    },
    /// Reading or writing the port failed.
    #[error("serial I/O on {path} failed: {source}")]
    Io {
        /// The port's path.
        path: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The device did not answer the `Hello`.
    #[error("no device answered Hello on {path} (waited {waited_ms} ms for its boot and 300 ms for the answer)")]
    NoHello {
        /// The port's path.
        path: PathBuf,
        /// How long the boot wait was, ms.
        waited_ms: u128,
    },
    /// The device speaks another major protocol version.
    #[error(transparent)]
    Version(#[from] VersionMismatch),
    /// The device understood the command and refused it.
    #[error("the device refused {command}: {reason}")]
    Refused {
        /// The command's name.
        command: &'static str,
        /// Why.
        reason: Refusal,
    },
    /// The device could not decode the command (a newer message, a bad field).
    #[error("the device rejected {command}: {status}")]
    Rejected {
        /// The command's name.
        command: &'static str,
        /// Its answer.
        status: AckStatus,
    },
    /// No answer after every try.
    #[error("no answer to {command} (seq {seq}) after {sends} sends")]
    NoAck {
        /// The command's name.
        command: &'static str,
        /// Its seq.
        seq: u8,
        /// How many times it was sent.
        sends: u32,
    },
    /// A `Stop` overtook the command, which was given up.
    #[error("{command} was given up: a Stop overtook it")]
    Overtaken {
        /// The command's name.
        command: &'static str,
    },
    /// The driver's thread could not start.
    #[error("cannot start the link's thread: {0}")]
    Spawn(std::io::Error),
    /// `Hello` is the handshake's, not a caller's, command.
    #[error("Hello is sent by the handshake only")]
    NotACommand,
    /// The port is gone (waiting to reconnect, or closed).
    #[error("the link is disconnected")]
    Disconnected,
}

/// A command the device accepted.
#[derive(Clone, Copy, Debug, PartialEq, Eq)]
pub struct Acked {
    /// Its seq.
    pub seq: Seq,
    /// From its first send to the answer.
    pub round_trip: Duration,
    /// How many times it was sent (1: no retry).
    pub sends: u32,
}

/// What the device reports on its own.
#[derive(Clone, Debug, PartialEq)]
pub enum Event {
    /// A `Telemetry` report.
    Telemetry(Telemetry),
    /// A fault was raised.
    Fault {
        /// Device time, ms.
        time_ms: u32,
        /// The fault's bit number.
        code: u8,
        /// The tube or cup it concerns.
        detail: u8,
    },
    /// A command (a heartbeat included) got no answer after every try: the
    /// link is failing, though the port is still open.
    NoAnswer {
        /// The command's name.
        command: &'static str,
        /// Its seq.
        seq: u8,
    },
    /// The port failed; the driver tries to reopen it.
    Disconnected,
    /// The port was reopened and the handshake done again.
    Reconnected(Hello),
    /// An unsolicited `Hello` in the middle of a session: the device reset
    /// (its configuration is lost, its pumps are off). [`Event::Restored`]
    /// follows.
    DeviceReset(Hello),
    /// The session's configuration was sent again after a reconnection or a
    /// reset (module rules).
    Restored(Restored),
}

/// What restoring the session did, per tube.
#[derive(Clone, Copy, Debug, Default, PartialEq, Eq)]
pub struct Restored {
    /// Tubes the device still had configured.
    pub kept: TubeSet,
    /// Tubes configured again, their length taken as the last measured.
    pub rezeroed: TubeSet,
    /// Tubes configured before but left unconfigured: their length was never
    /// measured, or the device refused the configuration.
    pub lost: TubeSet,
}

/// The link's health, for display and tests.
#[derive(Clone, Debug, Default, PartialEq)]
pub struct Health {
    /// The port is open and the handshake done.
    pub connected: bool,
    /// Round-trip times of the last answers, oldest first.
    pub round_trips: VecDeque<Duration>,
    /// Commands sent (first sends, heartbeats included).
    pub sent: u64,
    /// Sends again of a command without an answer.
    pub resends: u64,
    /// Commands given up without an answer.
    pub give_ups: u64,
    /// Frames the host received whose CRC matched.
    pub rx_frames: u64,
    /// Frames the host dropped for a CRC mismatch.
    pub bad_crc: u64,
    /// Frames the host dropped for anything else, and reports that do not
    /// decode.
    pub bad_frames: u64,
    /// Answers whose seq was not the one in flight.
    pub unexpected_seq: u64,
    /// Reports of a type this host does not know (a newer minor version).
    pub unknown_reports: u64,
    /// Telemetry reports received.
    pub telemetry: u64,
    /// The device's counters from its last telemetry.
    pub device: Option<LinkCounters>,
    /// Times the port was reopened.
    pub reconnects: u64,
    /// Times the session's configuration was sent again.
    pub restores: u64,
    /// The caller's command in flight (not the driver's own heartbeats or
    /// restoring commands), by name.
    pub in_flight: Option<&'static str>,
    /// Callers' commands queued behind it.
    pub queued: usize,
}

impl Health {
    /// The last round-trip time.
    pub fn last_round_trip(&self) -> Option<Duration> {
        self.round_trips.back().copied()
    }
}

/// A command waiting for the I/O thread, with where its outcome goes.
struct Request {
    command: Command,
    reply: Sender<Result<Acked, LinkError>>,
}

/// The command in flight.
struct InFlight {
    command: Command,
    pending: Pending,
    frame: [u8; MAX_FRAME],
    len: usize,
    first_sent: Instant,
    /// `None` for the driver's own heartbeats.
    reply: Option<Sender<Result<Acked, LinkError>>>,
}

/// State shared by the caller's handle and the I/O thread.
#[derive(Default)]
struct Shared {
    health: Mutex<Health>,
    subscribers: Mutex<Vec<Sender<Event>>>,
    hello: Mutex<Option<Hello>>,
    shutdown: AtomicBool,
}

fn lock<T>(mutex: &Mutex<T>) -> MutexGuard<'_, T> {
    // Plain data: a panic elsewhere leaves it usable.
    mutex.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
}

impl Shared {
    fn publish(&self, event: &Event) {
        lock(&self.subscribers).retain(|s| s.send(event.clone()).is_ok());
    }
}

/// An open link to a device.
pub struct Link {
    options: Options,
    requests: Option<Sender<Request>>,
    shared: Arc<Shared>,
    thread: Option<JoinHandle<()>>,
}

impl Link {
    /// Opens the serial port at `path`, does the handshake (see the module
    /// rules) and starts the reader.
    pub fn open(path: impl AsRef<Path>, options: Options) -> Result<Link, LinkError> {
        let path = path.as_ref().to_path_buf();
        let shared = Arc::new(Shared::default());
        let mut io = Io::connect(path, options, Arc::clone(&shared))?;
        let hello = io.handshake()?;
        *lock(&shared.hello) = Some(hello);
        lock(&shared.health).connected = true;
        let (requests, inbox) = mpsc::channel();
        let thread = std::thread::Builder::new()
            .name("leech-link".into())
            .spawn(move || io.run(&inbox))
            .map_err(LinkError::Spawn)?;
        Ok(Link { requests: Some(requests), shared, thread: Some(thread), options })
    }

    /// The device's `Hello` from the last handshake.
    pub fn hello(&self) -> Option<Hello> {
        *lock(&self.shared.hello)
    }

    /// The link's health now.
    pub fn health(&self) -> Health {
        lock(&self.shared.health).clone()
    }

    /// A channel receiving every event from now on (telemetry, faults,
    /// disconnections). Dropping the receiver unsubscribes.
    pub fn subscribe(&self) -> Receiver<Event> {
        let (sender, receiver) = mpsc::channel();
        lock(&self.shared.subscribers).push(sender);
        receiver
    }

    /// Sends `command` and waits for its outcome (any command but `Hello`).
    pub fn command(&self, command: Command) -> Result<Acked, LinkError> {
        if command == Command::Hello {
            return Err(LinkError::NotACommand);
        }
        let requests = self.requests.as_ref().ok_or(LinkError::Disconnected)?;
        let (reply, outcome) = mpsc::channel();
        requests.send(Request { command, reply }).map_err(|_| LinkError::Disconnected)?;
        // Every try takes 300 ms; a reconnection's handshake may hold the
        // I/O thread for the boot wait first (and then fails the commands
        // that waited, so that none runs after its caller gave up).
        let limit = self.options.boot_timeout + Duration::from_millis(300) + CALL_SLACK;
        match outcome.recv_timeout(limit) {
            Ok(result) => result,
            Err(_) => Err(LinkError::Disconnected),
        }
    }

    /// Moves every tube to a length, um.
    pub fn set_lengths(&self, lengths_um: [i32; 3]) -> Result<Acked, LinkError> {
        self.command(Command::SetLengths { lengths_um })
    }

    /// Moves one tube by a distance, um (positive lengthens).
    pub fn jog(&self, tube: Tube, delta_um: i32) -> Result<Acked, LinkError> {
        self.command(Command::Jog { tube, delta_um })
    }

    /// Stops every motor (pumps unchanged); overtakes the command in flight.
    pub fn stop(&self) -> Result<Acked, LinkError> {
        self.command(Command::Stop)
    }

    /// Switches a cup's pump.
    pub fn pump(&self, cup: Cup, on: bool) -> Result<Acked, LinkError> {
        self.command(Command::Pump { cup, on })
    }

    /// Telemetry every `period_ms` (at least 10), or off for 0.
    pub fn set_telemetry(&self, period_ms: u16) -> Result<Acked, LinkError> {
        self.command(Command::SetTelemetry { period_ms })
    }

    /// Clears latched faults.
    pub fn clear_faults(&self, faults: Faults) -> Result<Acked, LinkError> {
        self.command(Command::ClearFaults { faults })
    }

    /// Configures one tube (scale, limits, controller).
    pub fn configure_tube(&self, config: TubeConfig) -> Result<Acked, LinkError> {
        self.command(Command::ConfigureTube(config))
    }

    /// Configures the cups' holding thresholds.
    pub fn configure_cups(&self, config: CupConfig) -> Result<Acked, LinkError> {
        self.command(Command::ConfigureCups(config))
    }

    /// Closes the link: the reader stops and the port is closed.
    pub fn close(self) {}
}

impl Drop for Link {
    fn drop(&mut self) {
        self.shared.shutdown.store(true, Ordering::Relaxed);
        self.requests = None;
        if let Some(thread) = self.thread.take() {
            // The thread checks for shutdown every read timeout.
            let _ = thread.join();
        }
    }
}

/// What the device accepted in this session, to restore it (module rules).
#[derive(Clone, Copy, Debug, Default)]
struct Session {
    cups: Option<CupConfig>,
    tubes: [Option<TubeConfig>; 3],
    telemetry_ms: Option<u16>,
    /// Each configured tube's last measured length, um.
    lengths_um: [Option<i32>; 3],
}

impl Session {
    /// Remembers `command`, which the device accepted.
    fn accepted(&mut self, command: Command) {
        match command {
            Command::ConfigureCups(config) => self.cups = Some(config),
            Command::ConfigureTube(config) => self.tubes[config.tube.index()] = Some(config),
            Command::SetTelemetry { period_ms } => self.telemetry_ms = Some(period_ms),
            _ => {}
        }
    }

    /// `tube`'s configuration again, its origin re-zeroed so that `counts`
    /// read as its last measured length; `None` without one of the two.
    fn rezeroed(&self, tube: Tube, counts: i32) -> Option<TubeConfig> {
        let (config, length) = (self.tubes[tube.index()]?, self.lengths_um[tube.index()]?);
        let travel = i64::from(counts) * 1_000_000 / i64::from(config.counts_per_mm_x1000.max(1));
        let origin = (i64::from(length) - travel).clamp(i64::from(i32::MIN), i64::from(i32::MAX));
        // The clamp keeps it in range.
        Some(TubeConfig { origin_um: origin as i32, ..config })
    }
}

/// How long a restore waits for the first telemetry report.
const RESTORE_TELEMETRY_WAIT: Duration = Duration::from_secs(1);

/// The I/O side: owns the port.
struct Io {
    path: PathBuf,
    options: Options,
    shared: Arc<Shared>,
    port: Option<Box<dyn SerialPort>>,
    decoder: Decoder,
    seq: Seq,
    in_flight: Option<InFlight>,
    queue: VecDeque<Request>,
    last_send: Instant,
    start: Instant,
    reports: Vec<Report>,
    session: Session,
    /// The session must be restored before the next command.
    restore: bool,
    /// The last telemetry report.
    latest: Option<Telemetry>,
}

impl Io {
    fn connect(path: PathBuf, options: Options, shared: Arc<Shared>) -> Result<Io, LinkError> {
        let port = open_port(&path)?;
        let now = Instant::now();
        Ok(Io {
            path,
            options,
            shared,
            port: Some(port),
            decoder: Decoder::new(),
            seq: Seq::FIRST,
            in_flight: None,
            queue: VecDeque::new(),
            last_send: now,
            start: now,
            reports: Vec::new(),
            session: Session::default(),
            restore: false,
            latest: None,
        })
    }

    /// The host's wrapping millisecond clock.
    fn now_ms(&self) -> u32 {
        // Truncation is the wrap of a u32 clock.
        self.start.elapsed().as_millis() as u32
    }

    fn io_error(&self, source: std::io::Error) -> LinkError {
        LinkError::Io { path: self.path.clone(), source }
    }

    fn write(&mut self, bytes: &[u8]) -> Result<(), LinkError> {
        let port = self.port.as_mut().ok_or(LinkError::Disconnected)?;
        let result = port.write_all(bytes).and_then(|()| port.flush());
        self.last_send = Instant::now();
        result.map_err(|e| self.io_error(e))
    }

    /// Reads what the port has (waiting at most the read timeout) and
    /// decodes it into `self.reports`.
    fn read(&mut self) -> Result<(), LinkError> {
        let port = self.port.as_mut().ok_or(LinkError::Disconnected)?;
        let mut bytes = [0u8; 512];
        let n = match port.read(&mut bytes) {
            // A readable port with nothing to read has hung up.
            Ok(0) => return Err(self.io_error(ErrorKind::UnexpectedEof.into())),
            Ok(n) => n,
            Err(e) if matches!(e.kind(), ErrorKind::TimedOut | ErrorKind::WouldBlock | ErrorKind::Interrupted) => {
                return Ok(())
            }
            Err(e) => return Err(self.io_error(e)),
        };
        let mut health = lock(&self.shared.health);
        let before = self.decoder.counters();
        let mut rest = &bytes[..n];
        while !rest.is_empty() {
            let (event, more) = self.decoder.feed(rest);
            if let Some(Ok(message)) = event {
                match Report::decode(message) {
                    Ok(report) => self.reports.push(report),
                    Err(DecodeError::UnknownType { .. }) => health.unknown_reports += 1,
                    Err(_) => health.bad_frames += 1,
                }
            }
            rest = more;
        }
        let after = self.decoder.counters();
        health.rx_frames += u64::from(after.frames.wrapping_sub(before.frames));
        health.bad_crc += u64::from(after.bad_crc.wrapping_sub(before.bad_crc));
        health.bad_frames += u64::from(after.bad_frames.wrapping_sub(before.bad_frames));
        Ok(())
    }

    /// The session's start (module rules): wait for the boot `Hello`, then
    /// `Hello` with retries, then the version check.
    fn handshake(&mut self) -> Result<Hello, LinkError> {
        let boot_end = Instant::now() + self.options.boot_timeout;
        'boot: while Instant::now() < boot_end {
            self.read()?;
            for report in self.reports.drain(..) {
                if matches!(report, Report::Hello { reply_to: None, .. }) {
                    break 'boot;
                }
            }
        }
        self.reports.clear();
        self.write(&[0x00])?;
        self.seq = Seq::FIRST;
        let (frame, len) = encode(Command::Hello, self.seq);
        self.write(&frame[..len])?;
        let mut pending = Pending::new(self.seq, self.now_ms());
        loop {
            self.read()?;
            let answer = self.reports.drain(..).find_map(|report| match report {
                Report::Hello { hello, .. } if pending.is_answered_by(&report) => Some(hello),
                _ => None,
            });
            if let Some(hello) = answer {
                check_version(hello.protocol)?;
                return Ok(hello);
            }
            match pending.poll(self.now_ms()) {
                Retry::Wait => {}
                Retry::Resend => self.write(&frame[..len])?,
                Retry::GiveUp => {
                    return Err(LinkError::NoHello {
                        path: self.path.clone(),
                        waited_ms: self.options.boot_timeout.as_millis(),
                    })
                }
            }
        }
    }

    /// The I/O thread: until the handle is dropped.
    fn run(mut self, inbox: &Receiver<Request>) {
        let mut last_attempt = Instant::now();
        while !self.shared.shutdown.load(Ordering::Relaxed) {
            loop {
                match inbox.try_recv() {
                    Ok(request) => {
                        self.enqueue(request);
                        self.show_queue();
                    }
                    Err(mpsc::TryRecvError::Empty) => break,
                    Err(mpsc::TryRecvError::Disconnected) => return,
                }
            }
            if self.port.is_none() {
                for request in self.queue.drain(..) {
                    // The caller may have given up waiting.
                    let _ = request.reply.send(Err(LinkError::Disconnected));
                }
                if self.options.reconnect && last_attempt.elapsed() >= self.options.reconnect_interval {
                    last_attempt = Instant::now();
                    self.reconnect(inbox);
                }
                std::thread::sleep(READ_TIMEOUT);
                continue;
            }
            if self.turn().is_err() {
                self.disconnect();
            }
            self.show_queue();
        }
    }

    /// One turn of a connected link: send, read, route, retry.
    fn turn(&mut self) -> Result<(), LinkError> {
        if self.restore && self.in_flight.is_none() {
            self.restore = false;
            self.restore_session()?;
        }
        if self.in_flight.is_none() {
            if let Some(request) = self.queue.pop_front() {
                self.start(request.command, Some(request.reply))?;
            } else if self.last_send.elapsed() >= Duration::from_millis(u64::from(HEARTBEAT_MS)) {
                self.start(Command::Heartbeat, None)?;
            }
        }
        self.read()?;
        let reports = std::mem::take(&mut self.reports);
        for report in reports {
            self.route(report);
        }
        self.retry()
    }

    /// Resends the command in flight, or gives it up, when its time came.
    fn retry(&mut self) -> Result<(), LinkError> {
        let now = self.now_ms();
        let Some(flight) = self.in_flight.as_mut() else { return Ok(()) };
        match flight.pending.poll(now) {
            Retry::Wait => Ok(()),
            Retry::Resend => {
                let (frame, len) = (flight.frame, flight.len);
                lock(&self.shared.health).resends += 1;
                self.write(&frame[..len])
            }
            Retry::GiveUp => {
                lock(&self.shared.health).give_ups += 1;
                if let Some(flight) = self.in_flight.take() {
                    let (command, seq) = (name(&flight.command), flight.pending.seq().get());
                    self.shared.publish(&Event::NoAnswer { command, seq });
                    finish(flight.reply, Err(LinkError::NoAck { command, seq, sends: flight.pending.sends() }));
                }
                Ok(())
            }
        }
    }

    /// Queues a caller's command; a `Stop` overtakes the command in flight
    /// and every command queued before it that is not a `Stop` (motion
    /// asked for before an emergency stop must not run after it).
    fn enqueue(&mut self, request: Request) {
        if request.command != Command::Stop {
            self.queue.push_back(request);
            return;
        }
        // A Stop already in flight goes on: it does what the new one would.
        if let Some(flight) = self.in_flight.take_if(|f| f.command != Command::Stop) {
            finish(flight.reply, Err(LinkError::Overtaken { command: name(&flight.command) }));
        }
        let (stops, overtaken): (VecDeque<Request>, VecDeque<Request>) =
            std::mem::take(&mut self.queue).into_iter().partition(|r| r.command == Command::Stop);
        for request in overtaken {
            let _ = request.reply.send(Err(LinkError::Overtaken { command: name(&request.command) }));
        }
        self.queue = stops;
        self.queue.push_front(request);
    }

    /// What waits, for [`Health`].
    fn show_queue(&self) {
        let mut health = lock(&self.shared.health);
        health.in_flight = self.in_flight.as_ref().filter(|f| f.reply.is_some()).map(|f| name(&f.command));
        health.queued = self.queue.len();
    }

    /// Sends a new command with the next seq.
    fn start(&mut self, command: Command, reply: Option<Sender<Result<Acked, LinkError>>>) -> Result<(), LinkError> {
        self.seq = self.seq.next();
        let (frame, len) = encode(command, self.seq);
        let pending = Pending::new(self.seq, self.now_ms());
        self.in_flight = Some(InFlight { command, pending, frame, len, first_sent: Instant::now(), reply });
        lock(&self.shared.health).sent += 1;
        self.write(&frame[..len])
    }

    /// Hands a report to whom it concerns.
    fn route(&mut self, report: Report) {
        match report {
            Report::Ack { seq, status } => {
                let Some(flight) = self.in_flight.take_if(|f| f.pending.is_answered_by(&report)) else {
                    lock(&self.shared.health).unexpected_seq += 1;
                    return;
                };
                let round_trip = flight.first_sent.elapsed();
                {
                    let mut health = lock(&self.shared.health);
                    if health.round_trips.len() == LATENCY_WINDOW {
                        health.round_trips.pop_front();
                    }
                    health.round_trips.push_back(round_trip);
                }
                let command = name(&flight.command);
                if status == AckStatus::Ok {
                    self.session.accepted(flight.command);
                }
                let outcome = match status {
                    AckStatus::Ok => Ok(Acked { seq, round_trip, sends: flight.pending.sends() }),
                    AckStatus::Refused(reason) => Err(LinkError::Refused { command, reason }),
                    status => Err(LinkError::Rejected { command, status }),
                };
                finish(flight.reply, outcome);
            }
            Report::Telemetry(telemetry) => {
                {
                    let mut health = lock(&self.shared.health);
                    health.telemetry += 1;
                    health.device = Some(telemetry.counters);
                }
                for tube in Tube::ALL {
                    if telemetry.configured.contains(tube) {
                        self.session.lengths_um[tube.index()] = Some(telemetry.lengths_um[tube.index()]);
                    }
                }
                self.latest = Some(telemetry);
                self.shared.publish(&Event::Telemetry(telemetry));
            }
            Report::Fault { time_ms, code, detail } => self.shared.publish(&Event::Fault { time_ms, code, detail }),
            Report::Hello { reply_to: None, hello } => {
                self.restore = true;
                self.shared.publish(&Event::DeviceReset(hello));
            }
            // An answer to a Hello of an earlier handshake.
            Report::Hello { reply_to: Some(_), .. } => lock(&self.shared.health).unexpected_seq += 1,
        }
    }

    /// The port failed: fail what waits, and close it.
    fn disconnect(&mut self) {
        self.port = None;
        lock(&self.shared.health).connected = false;
        if let Some(flight) = self.in_flight.take() {
            finish(flight.reply, Err(LinkError::Disconnected));
        }
        self.shared.publish(&Event::Disconnected);
    }

    /// One attempt at reopening the port and doing the handshake again.
    fn reconnect(&mut self, inbox: &Receiver<Request>) {
        let Ok(port) = open_port(&self.path) else { return };
        self.port = Some(port);
        self.decoder = Decoder::new();
        let handshake = self.handshake();
        // Commands that came during the handshake were sent to a
        // disconnected link: they fail rather than run late. (Before the
        // news of the reconnection, so that none sent after it fails.)
        while let Ok(request) = inbox.try_recv() {
            let _ = request.reply.send(Err(LinkError::Disconnected));
        }
        match handshake {
            Ok(hello) => {
                *lock(&self.shared.hello) = Some(hello);
                let mut health = lock(&self.shared.health);
                health.connected = true;
                health.reconnects += 1;
                drop(health);
                self.last_send = Instant::now();
                self.shared.publish(&Event::Reconnected(hello));
                self.restore = true;
            }
            Err(_) => self.port = None,
        }
    }

    /// Sends the session's configuration again (module rules), one command
    /// at a time, before any caller's command.
    fn restore_session(&mut self) -> Result<(), LinkError> {
        let session = self.session;
        if let Some(config) = session.cups {
            self.exchange(Command::ConfigureCups(config))?;
        }
        let mut restored = Restored::default();
        if session.tubes.iter().any(Option::is_some) {
            // Which tubes the device still has, and their counts, from a
            // telemetry report asked for now.
            self.latest = None;
            self.exchange(Command::SetTelemetry { period_ms: 10 })?;
            let end = Instant::now() + RESTORE_TELEMETRY_WAIT;
            while self.latest.is_none() && Instant::now() < end {
                self.read()?;
                for report in std::mem::take(&mut self.reports) {
                    self.route(report);
                }
            }
            for tube in Tube::ALL.into_iter().filter(|t| session.tubes[t.index()].is_some()) {
                let Some(latest) = self.latest else {
                    restored.lost = restored.lost.with(tube, true);
                    continue;
                };
                if latest.configured.contains(tube) {
                    restored.kept = restored.kept.with(tube, true);
                    continue;
                }
                let config = session.rezeroed(tube, latest.counts[tube.index()]);
                let accepted = match config {
                    Some(config) => self.exchange(Command::ConfigureTube(config))? == AckStatus::Ok,
                    None => false,
                };
                if accepted {
                    restored.rezeroed = restored.rezeroed.with(tube, true);
                } else {
                    restored.lost = restored.lost.with(tube, true);
                }
            }
        }
        self.exchange(Command::SetTelemetry { period_ms: session.telemetry_ms.unwrap_or(0) })?;
        lock(&self.shared.health).restores += 1;
        self.shared.publish(&Event::Restored(restored));
        Ok(())
    }

    /// Sends the driver's own `command` and waits for its answer (with the
    /// protocol's retries), routing everything else that arrives meanwhile.
    fn exchange(&mut self, command: Command) -> Result<AckStatus, LinkError> {
        let (tx, rx) = mpsc::channel();
        self.start(command, Some(tx))?;
        while self.in_flight.is_some() {
            self.read()?;
            for report in std::mem::take(&mut self.reports) {
                self.route(report);
            }
            self.retry()?;
        }
        match rx.try_recv() {
            Ok(Ok(_)) => Ok(AckStatus::Ok),
            Ok(Err(LinkError::Refused { reason, .. })) => Ok(AckStatus::Refused(reason)),
            Ok(Err(LinkError::Rejected { status, .. })) => Ok(status),
            Ok(Err(error)) => Err(error),
            Err(_) => Err(LinkError::Disconnected),
        }
    }
}

/// Opens `path` at the protocol's line settings.
fn open_port(path: &Path) -> Result<Box<dyn SerialPort>, LinkError> {
    serialport::new(path.to_string_lossy(), BAUD_RATE)
        .data_bits(serialport::DataBits::Eight)
        .parity(serialport::Parity::None)
        .stop_bits(serialport::StopBits::One)
        .flow_control(serialport::FlowControl::None)
        .timeout(READ_TIMEOUT)
        .open()
        .map_err(|source| LinkError::Open { path: path.to_path_buf(), source })
}

/// A command's frame.
fn encode(command: Command, seq: Seq) -> ([u8; MAX_FRAME], usize) {
    let mut frame = [0u8; MAX_FRAME];
    // Every command fits a MAX_FRAME buffer.
    let len = command.encode_frame(seq, &mut frame).unwrap_or(0);
    (frame, len)
}

/// A command's name for messages.
fn name(command: &Command) -> &'static str {
    types::name(command.type_byte()).unwrap_or("a command")
}

/// Hands an outcome to the caller waiting for it, if any still does.
fn finish(reply: Option<Sender<Result<Acked, LinkError>>>, outcome: Result<Acked, LinkError>) {
    if let Some(reply) = reply {
        let _ = reply.send(outcome);
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::pty::PtyDevice;
    use crate::sim::{Sim, SimConfig};

    /// A request and where its outcome arrives.
    fn request(command: Command) -> (Request, Receiver<Result<Acked, LinkError>>) {
        let (reply, outcome) = mpsc::channel();
        (Request { command, reply }, outcome)
    }

    fn overtaken(outcome: &Receiver<Result<Acked, LinkError>>, what: &str) {
        match outcome.try_recv() {
            Ok(Err(LinkError::Overtaken { command })) => assert_eq!(command, what),
            other => panic!("{what}: {other:?}"),
        }
    }

    /// Without the I/O thread: the queue's order is the test's, not the
    /// scheduler's.
    #[test]
    fn a_stop_fails_the_command_in_flight_and_every_queued_one_but_stops() {
        let device = PtyDevice::spawn(Sim::new(SimConfig::default())).expect("a pseudo-terminal");
        let mut io =
            Io::connect(device.path().to_path_buf(), Options::default(), Arc::default()).expect("the port opens");
        let (moving, moving_outcome) = request(Command::SetLengths { lengths_um: [200_000; 3] });
        io.enqueue(moving);
        let first = io.queue.pop_front().expect("queued");
        io.start(first.command, Some(first.reply)).expect("sent");
        let (jog, jog_outcome) = request(Command::Jog { tube: Tube::L1, delta_um: 1000 });
        let (stop, stop_outcome) = request(Command::Stop);
        let (pump, pump_outcome) = request(Command::Pump { cup: Cup::Rear, on: true });
        io.enqueue(jog);
        io.enqueue(stop);
        io.enqueue(pump);
        // An emergency stop: nothing asked for before it runs after it.
        let (again, again_outcome) = request(Command::Stop);
        io.enqueue(again);
        overtaken(&moving_outcome, "SetLengths");
        overtaken(&jog_outcome, "Jog");
        overtaken(&pump_outcome, "Pump");
        assert!(io.in_flight.is_none());
        let queued: Vec<Command> = io.queue.iter().map(|r| r.command).collect();
        assert_eq!(queued, [Command::Stop, Command::Stop]);
        assert!(stop_outcome.try_recv().is_err() && again_outcome.try_recv().is_err(), "the Stops wait");
        // A Stop in flight is not given up for another.
        let first = io.queue.pop_front().expect("a Stop");
        io.start(first.command, Some(first.reply)).expect("sent");
        let (third, third_outcome) = request(Command::Stop);
        io.enqueue(third);
        assert!(io.in_flight.as_ref().is_some_and(|f| f.command == Command::Stop));
        assert!(stop_outcome.try_recv().is_err() && third_outcome.try_recv().is_err());
        assert_eq!(io.queue.len(), 2);
    }
}
