//! The robot's Arduino firmware on a simulated ATmega2560: a device a host
//! opens like a real Mega, for testing the host against the firmware itself.
//!
//! Rules:
//!
//! * [`build`] runs the repository's `firmware/build.sh`, which compiles the
//!   sketch (`firmware/leech/`, Debian's gcc-avr and arduino-mk) into
//!   `leech.elf` and the harness `leech-simavr` (`firmware/simavr/`,
//!   Debian's libsimavr) into one directory ([`Built`]).
//! * [`Chip::spawn`] starts `leech-simavr` on the ELF. The harness runs the
//!   chip at 16 MHz in real time (never ahead of the wall clock; behind it
//!   when the machine is busy), inside a simulated robot: three DC motors
//!   whose PWM duty and direction it reads from the pins and whose encoders
//!   it toggles into the chip's interrupt pins, and two pumps with vacuum
//!   sensors on the ADC. The chip's UART0 is a pseudo-terminal:
//!   [`Chip::path`].
//! * The harness prints the robot's state every 10 ms of simulated time
//!   ([`Chip::spawn_with`] sets another period, down to 1 ms for a step
//!   response); [`Chip::observe`] gives the latest ([`ChipState`]): what the
//!   hardware does, measured outside the protocol. [`Chip::states`] gives
//!   every one from then on, for a record.
//! * [`Chip::harness`] injects the robot's faults (a stalled motor, a cup that
//!   leaks) through the harness's stdin.
//! * Dropping the [`Chip`] closes the harness's stdin, which ends it (and
//!   kills it if it has not ended within 2 s); the pseudo-terminal goes with
//!   it.

use std::io::{BufRead, BufReader, Write};
use std::path::{Path, PathBuf};
use std::process::{Child, ChildStdin, Command, Stdio};
use std::sync::mpsc::{self, Receiver, Sender};
use std::sync::{Arc, Mutex, OnceLock, PoisonError};
use std::time::{Duration, Instant};

use serde::Deserialize;

/// Why the firmware could not be built or started.
#[derive(Debug, thiserror::Error)]
pub enum ChipError {
    /// `firmware/build.sh` could not run or failed.
    #[error("building the firmware failed ({why}); firmware/install-deps.sh installs what it needs")]
    Build {
        /// What happened.
        why: String,
    },
    /// The harness could not start.
    #[error("cannot start {harness}: {source}")]
    Spawn {
        /// The harness's path.
        harness: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// The harness did not say its port.
    #[error("leech-simavr did not say its port (its first line: {line:?})")]
    NoPort {
        /// What it said instead.
        line: String,
    },
}

/// The firmware and its harness, built.
#[derive(Clone, Debug, PartialEq, Eq)]
pub struct Built {
    /// The firmware's ELF.
    pub elf: PathBuf,
    /// The `leech-simavr` harness.
    pub harness: PathBuf,
}

/// Builds the firmware of the repository at `root` and its harness into
/// `out` (the build's output is not shown).
pub fn build(root: &Path, out: &Path) -> Result<Built, ChipError> {
    let status = Command::new("bash")
        .arg(root.join("firmware/build.sh"))
        .arg(out)
        .stdout(Stdio::null())
        .status()
        .map_err(|e| ChipError::Build { why: format!("cannot run bash: {e}") })?;
    if !status.success() {
        return Err(ChipError::Build { why: format!("firmware/build.sh: {status}") });
    }
    Ok(Built { elf: out.join("leech.elf"), harness: out.join("leech-simavr") })
}

/// Builds the firmware of the repository this crate was compiled from (for
/// its tests, benches and examples) into `out`, once per process: later
/// calls return the first build's outcome, whatever their `out`.
pub fn build_once(out: &Path) -> Result<&'static Built, ChipError> {
    static BUILT: OnceLock<Result<Built, String>> = OnceLock::new();
    let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
    let built = BUILT.get_or_init(|| {
        build(&root, out).map_err(|e| match e {
            ChipError::Build { why } => why,
            other => other.to_string(),
        })
    });
    built.as_ref().map_err(|why| ChipError::Build { why: why.clone() })
}

/// The simulated robot around the chip, as the harness last reported it.
#[derive(Clone, Copy, Debug, Default, PartialEq, Deserialize)]
pub struct ChipState {
    /// Simulated time since the chip started, ms.
    pub t_ms: f64,
    /// Motor drive per tube, per mille (positive lengthens; 0 braking or
    /// coasting).
    pub duty_permille: [i32; 3],
    /// Per tube: 1 while the driver brakes (IN1 = IN2 = high).
    pub brake: [u8; 3],
    /// Pumps running (rear, front): 1 on.
    pub pumps: [u8; 2],
    /// True tube lengths, um.
    pub lengths_um: [f64; 3],
    /// Encoder counts the chip has been shown.
    pub counts: [i64; 3],
    /// True vacuum in each cup, 0.1 kPa.
    pub vacuum_kpa_x10: [f64; 2],
    /// Simulated seconds per wall second over the last second.
    pub sim_rate: f64,
    /// With [`Chip::spawn_profiled`], since the previous state: the control
    /// ticks that ended (the Timer5 interrupt's entry to the chip's next
    /// sleep).
    #[serde(default)]
    pub ticks: u32,
    /// Their mean length, us of simulated time (cycle-exact).
    #[serde(default)]
    pub tick_us_mean: f64,
    /// The longest, us.
    #[serde(default)]
    pub tick_us_max: f64,
    /// The fraction of the time the chip was not asleep.
    #[serde(default)]
    pub busy: f64,
}

/// The firmware running on a simulated chip (module rules).
pub struct Chip {
    child: Child,
    /// The harness's command input; `None` once closed.
    stdin: Mutex<Option<ChildStdin>>,
    path: PathBuf,
    latest: Arc<Mutex<Option<ChipState>>>,
    records: Arc<Mutex<Vec<Sender<ChipState>>>>,
}

impl Chip {
    /// Starts `built`'s harness on its firmware, reporting the robot's
    /// state every 10 ms.
    pub fn spawn(built: &Built) -> Result<Chip, ChipError> {
        Chip::spawn_with(built, 10)
    }

    /// Starts `built`'s harness on its firmware, reporting the robot's
    /// state every `state_every_ms` ms of simulated time (at least 1).
    pub fn spawn_with(built: &Built, state_every_ms: u32) -> Result<Chip, ChipError> {
        Chip::start(built, state_every_ms, false)
    }

    /// As [`Chip::spawn_with`], the harness also measuring the firmware's
    /// control ticks and how busy the chip is ([`ChipState::tick_us_mean`]
    /// and the fields after it; harness option `--profile`).
    pub fn spawn_profiled(built: &Built, state_every_ms: u32) -> Result<Chip, ChipError> {
        Chip::start(built, state_every_ms, true)
    }

    fn start(built: &Built, state_every_ms: u32, profile: bool) -> Result<Chip, ChipError> {
        let spawn_error = |source| ChipError::Spawn { harness: built.harness.clone(), source };
        let mut child = Command::new(&built.harness)
            .arg(&built.elf)
            .arg("--state-every-ms")
            .arg(state_every_ms.max(1).to_string())
            .args(profile.then_some("--profile"))
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .map_err(spawn_error)?;
        let stdin = child.stdin.take();
        let Some(stdout) = child.stdout.take() else {
            let _ = child.kill();
            return Err(ChipError::NoPort { line: String::new() });
        };
        let mut lines = BufReader::new(stdout);
        let mut first = String::new();
        let read = lines.read_line(&mut first);
        let Some(path) = first.trim().strip_prefix("port ").filter(|_| read.is_ok()).map(PathBuf::from) else {
            let _ = child.kill();
            let _ = child.wait();
            return Err(ChipError::NoPort { line: first });
        };
        let latest = Arc::new(Mutex::new(None));
        let records: Arc<Mutex<Vec<Sender<ChipState>>>> = Arc::default();
        // The reader ends when the harness closes its stdout (it exited).
        std::thread::spawn({
            let latest = Arc::clone(&latest);
            let records = Arc::clone(&records);
            move || {
                for line in lines.lines().map_while(Result::ok) {
                    if let Ok(state) = serde_json::from_str::<ChipState>(&line) {
                        *latest.lock().unwrap_or_else(PoisonError::into_inner) = Some(state);
                        // A record whose receiver is gone is forgotten.
                        records.lock().unwrap_or_else(PoisonError::into_inner).retain(|r| r.send(state).is_ok());
                    }
                }
            }
        });
        Ok(Chip { child, stdin: Mutex::new(stdin), path, latest, records })
    }

    /// Sends the harness one command line (its README: `stall M`,
    /// `free M` for motor M = 0..=2; `vacuum-loss C`, `seal C` for cup C =
    /// 0 rear, 1 front): a fault of the robot, outside the chip.
    pub fn harness(&self, command: &str) -> std::io::Result<()> {
        let mut stdin = self.stdin.lock().unwrap_or_else(PoisonError::into_inner);
        let stdin = stdin.as_mut().ok_or_else(|| std::io::Error::from(std::io::ErrorKind::BrokenPipe))?;
        writeln!(stdin, "{command}")?;
        stdin.flush()
    }

    /// The pseudo-terminal a host opens as the Mega's serial port.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Every state the harness reports from now on, in order (until the
    /// receiver is dropped or the harness ends).
    pub fn states(&self) -> Receiver<ChipState> {
        let (sender, receiver) = mpsc::channel();
        self.records.lock().unwrap_or_else(PoisonError::into_inner).push(sender);
        receiver
    }

    /// The latest state the harness reported, waiting up to `limit` for the
    /// first one.
    pub fn observe(&self, limit: Duration) -> Option<ChipState> {
        let end = Instant::now() + limit;
        loop {
            if let Some(state) = *self.latest.lock().unwrap_or_else(PoisonError::into_inner) {
                return Some(state);
            }
            if Instant::now() >= end {
                return None;
            }
            std::thread::sleep(Duration::from_millis(5));
        }
    }
}

impl Drop for Chip {
    fn drop(&mut self) {
        // Closing its stdin ends the harness; a kill if it does not.
        drop(self.stdin.lock().unwrap_or_else(PoisonError::into_inner).take());
        let end = Instant::now() + Duration::from_secs(2);
        while Instant::now() < end {
            if let Ok(Some(_)) = self.child.try_wait() {
                return;
            }
            std::thread::sleep(Duration::from_millis(10));
        }
        let _ = self.child.kill();
        let _ = self.child.wait();
    }
}
