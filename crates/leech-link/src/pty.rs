//! A simulated device behind a pseudo-terminal: what a host opens as a
//! serial port is a [`Sim`] running in real time.
//!
//! Rules:
//!
//! * The pseudo-terminal is opened with `openpty`; its slave side is put in
//!   raw mode (no echo, no line editing, no byte translation), so frames
//!   pass untouched. [`PtyDevice::path`] is the slave's path, a runtime
//!   value (`/dev/pts/N` on Linux) that a host opens as its serial port; the
//!   baud rate it sets is accepted and ignored (bytes move as fast as the
//!   two processes read them).
//! * A background thread owns the master side. Every [`TICK`] (1 ms) it
//!   reads what the host wrote, advances the simulation by the real time
//!   elapsed, at most [`MAX_STEP`], and writes what the device sent. A
//!   thread starved by a busy machine so loses time rather than judging the
//!   link by it: the host's frames that waited in the terminal meanwhile
//!   were sent in time, and stepping the whole gap at once after them would
//!   make the device see a silent link (as a real controller, which never
//!   stalls, would not). While no host reads, the
//!   terminal's buffer fills and further device bytes are dropped (at most
//!   [`BACKLOG`] bytes wait), as on a serial line with nobody listening.
//! * The device keeps the slave side open itself, so that hosts may close
//!   and reopen the path while it runs; the path goes away when the
//!   [`PtyDevice`] is stopped or dropped. Both stop the thread and join it
//!   (it checks for the request every tick, so within a few ms).

use std::fs::File;
use std::io::{ErrorKind, Read, Write};
use std::os::fd::{AsFd, OwnedFd};
use std::path::{Path, PathBuf};
use std::sync::atomic::{AtomicBool, Ordering};
use std::sync::{Arc, Mutex, MutexGuard};
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use nix::fcntl::{fcntl, FcntlArg, OFlag};
use nix::pty::openpty;
use nix::sys::termios::{cfmakeraw, tcgetattr, tcsetattr, SetArg};

use crate::sim::{Faults, Sim, SimState};

/// The device thread's period.
pub const TICK: Duration = Duration::from_millis(1);

/// The longest simulated step after a stall of the device thread.
pub const MAX_STEP: Duration = Duration::from_millis(20);

/// The most device bytes kept waiting for a host to read them.
pub const BACKLOG: usize = 4096;

/// Why a pseudo-terminal device could not start.
#[derive(Debug, thiserror::Error)]
pub enum PtyError {
    /// `openpty` failed.
    #[error("cannot open a pseudo-terminal: {0}")]
    Open(nix::Error),
    /// The slave side could not be put in raw mode, or the master side in
    /// non-blocking mode.
    #[error("cannot set up the pseudo-terminal's modes: {0}")]
    Mode(nix::Error),
    /// The slave side's path could not be found.
    #[error("cannot find the pseudo-terminal's path: {0}")]
    Name(nix::Error),
    /// The device thread could not start.
    #[error("cannot start the device thread: {0}")]
    Spawn(std::io::Error),
}

/// A [`Sim`] running behind a pseudo-terminal, on its own thread.
pub struct PtyDevice {
    path: PathBuf,
    sim: Arc<Mutex<Sim>>,
    stop: Arc<AtomicBool>,
    thread: Option<JoinHandle<()>>,
    /// Held open so that hosts can come and go (see the module rules).
    _slave: OwnedFd,
}

impl PtyDevice {
    /// Starts `sim` behind a new pseudo-terminal; its `Hello` is sent at once.
    pub fn spawn(sim: Sim) -> Result<PtyDevice, PtyError> {
        let pty = openpty(None, None).map_err(PtyError::Open)?;
        let mut modes = tcgetattr(&pty.slave).map_err(PtyError::Mode)?;
        cfmakeraw(&mut modes);
        tcsetattr(&pty.slave, SetArg::TCSANOW, &modes).map_err(PtyError::Mode)?;
        fcntl(pty.master.as_fd(), FcntlArg::F_SETFL(OFlag::O_NONBLOCK)).map_err(PtyError::Mode)?;
        let path = nix::unistd::ttyname(&pty.slave).map_err(PtyError::Name)?;

        let sim = Arc::new(Mutex::new(sim));
        let stop = Arc::new(AtomicBool::new(false));
        let master = File::from(pty.master);
        let thread = std::thread::Builder::new()
            .name("leech-sim-pty".into())
            .spawn({
                let (sim, stop) = (Arc::clone(&sim), Arc::clone(&stop));
                move || run(master, &sim, &stop)
            })
            .map_err(PtyError::Spawn)?;
        Ok(PtyDevice { path, sim, stop, thread: Some(thread), _slave: pty.slave })
    }

    /// The path a host opens as its serial port.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// A snapshot of the simulated robot.
    pub fn state(&self) -> SimState {
        self.lock().state()
    }

    /// Injects `faults` from now on.
    pub fn set_faults(&self, faults: Faults) {
        self.lock().set_faults(faults);
    }

    /// Runs `f` on the simulation, with the device thread paused.
    pub fn with_sim<R>(&self, f: impl FnOnce(&mut Sim) -> R) -> R {
        f(&mut self.lock())
    }

    /// Stops the device: its thread ends and the path goes away.
    pub fn stop(self) {}

    fn lock(&self) -> MutexGuard<'_, Sim> {
        // A panic on the device thread leaves a usable simulation behind.
        self.sim.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }
}

impl Drop for PtyDevice {
    fn drop(&mut self) {
        self.stop.store(true, Ordering::Relaxed);
        if let Some(thread) = self.thread.take() {
            // The thread checks `stop` every tick; a panic there is over too.
            let _ = thread.join();
        }
    }
}

/// The device thread: host bytes in, real time on, device bytes out.
fn run(mut master: File, sim: &Mutex<Sim>, stop: &AtomicBool) {
    let mut last = Instant::now();
    let mut inbound = [0u8; 1024];
    let mut outbound = Vec::new();
    while !stop.load(Ordering::Relaxed) {
        let mut received = Vec::new();
        loop {
            match master.read(&mut inbound) {
                Ok(0) => break,
                Ok(n) => received.extend_from_slice(&inbound[..n]),
                // WouldBlock: nothing more for now; EIO: no host has the
                // slave open (while ours is, rarely); either way, go on.
                Err(_) => break,
            }
        }
        let now = Instant::now();
        {
            let mut sim = sim.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
            sim.receive(&received);
            sim.step(now.duration_since(last).min(MAX_STEP).as_secs_f64());
            sim.take_output(&mut outbound);
        }
        last = now;
        while !outbound.is_empty() {
            match master.write(&outbound) {
                Ok(0) => break,
                Ok(n) => drop(outbound.drain(..n)),
                Err(e) if e.kind() == ErrorKind::Interrupted => {}
                Err(_) => break,
            }
        }
        if outbound.len() > BACKLOG {
            outbound.drain(..outbound.len() - BACKLOG);
        }
        std::thread::sleep(TICK);
    }
}
