//! The devices the protocol suite runs against: the Rust simulated robot
//! behind a pseudo-terminal, and (feature `firmware`) the Arduino firmware on
//! a simulated ATmega2560 (`leech-simavr`, built from `firmware/`).
//!
//! Each gives the path a host opens, the identity it should say in its
//! `Hello`, and what its hardware does, observed outside the protocol: the
//! simulation's state, or the harness's pin-level JSON lines.

use std::path::Path;

use leech_link::pty::PtyDevice;
use leech_link::sim::{Sim, SimConfig};
use leech_protocol::message::DeviceKind;

/// The robot's hardware, observed outside the protocol.
#[derive(Clone, Copy, Debug, Default, PartialEq)]
pub struct Observed {
    /// The device's own clock, ms (simulated time).
    pub t_ms: f64,
    /// Motor drive per tube, per mille (positive lengthens).
    pub duty_permille: [i32; 3],
    /// Pumps running (rear, front).
    pub pumps: [bool; 2],
    /// True tube lengths, um.
    pub lengths_um: [f64; 3],
}

/// A device under test.
pub trait Target {
    /// The port a host opens.
    fn path(&self) -> &Path;
    /// What its `Hello` must say it is.
    fn kind(&self) -> DeviceKind;
    /// Its hardware now.
    fn observe(&self) -> Observed;
}

/// The hardware both targets simulate: 45 counts per mm, tubes 200 mm long
/// at power-up (the harness's robot is the simulation's default).
pub fn hardware() -> SimConfig {
    SimConfig::default()
}

impl Target for PtyDevice {
    fn path(&self) -> &Path {
        PtyDevice::path(self)
    }

    fn kind(&self) -> DeviceKind {
        DeviceKind::SIMULATOR
    }

    fn observe(&self) -> Observed {
        let state = self.state();
        Observed {
            t_ms: state.time_s * 1e3,
            duty_permille: state.duty_permille.map(i32::from),
            pumps: state.pumps,
            lengths_um: state.lengths_um,
        }
    }
}

/// The Rust simulated robot, fresh.
pub fn sim() -> PtyDevice {
    PtyDevice::spawn(Sim::new(hardware())).expect("a pseudo-terminal")
}

#[cfg(feature = "firmware")]
pub use firmware::firmware;

#[cfg(feature = "firmware")]
mod firmware {
    //! The firmware on `leech-simavr`. The firmware and the harness are
    //! built once per test run by `firmware/build.sh` into this test
    //! binary's scratch directory. One chip runs at a time: the simulator
    //! keeps real time only with a core to itself on a 2-core machine.

    use std::io::{BufRead, BufReader};
    use std::path::{Path, PathBuf};
    use std::process::{Child, ChildStdin, Command, Stdio};
    use std::sync::{Arc, Mutex, MutexGuard, OnceLock};
    use std::time::{Duration, Instant};

    use leech_protocol::message::DeviceKind;
    use serde_json::Value;

    use super::{Observed, Target};

    /// Where the build put the firmware and the harness.
    struct Built {
        elf: PathBuf,
        harness: PathBuf,
    }

    fn built() -> &'static Built {
        static BUILT: OnceLock<Built> = OnceLock::new();
        BUILT.get_or_init(|| {
            let root = Path::new(env!("CARGO_MANIFEST_DIR")).join("../..");
            let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("firmware");
            let status = Command::new("bash")
                .arg(root.join("firmware/build.sh"))
                .arg(&out)
                .stdout(Stdio::null())
                .status()
                .expect("bash runs firmware/build.sh");
            assert!(
                status.success(),
                "firmware/build.sh failed ({status}); firmware/install-deps.sh installs what it needs"
            );
            Built { elf: out.join("leech.elf"), harness: out.join("leech-simavr") }
        })
    }

    /// One chip at a time (module doc).
    fn one_at_a_time() -> MutexGuard<'static, ()> {
        static CHIP: Mutex<()> = Mutex::new(());
        CHIP.lock().unwrap_or_else(|poisoned| poisoned.into_inner())
    }

    /// The firmware running on a simulated chip in a simulated robot.
    pub struct Firmware {
        child: Child,
        stdin: Option<ChildStdin>,
        path: PathBuf,
        latest: Arc<Mutex<Option<Observed>>>,
        _chip: MutexGuard<'static, ()>,
    }

    /// The firmware, just started.
    pub fn firmware() -> Firmware {
        let built = built();
        let chip = one_at_a_time();
        let mut child = Command::new(&built.harness)
            .arg(&built.elf)
            .stdin(Stdio::piped())
            .stdout(Stdio::piped())
            .stderr(Stdio::inherit())
            .spawn()
            .expect("leech-simavr starts");
        let stdin = child.stdin.take();
        let mut lines = BufReader::new(child.stdout.take().expect("its stdout"));
        let mut first = String::new();
        lines.read_line(&mut first).expect("leech-simavr's first line");
        let path = PathBuf::from(first.trim().strip_prefix("port ").expect("`port PATH` first"));
        let latest = Arc::new(Mutex::new(None));
        // The reader ends when the harness closes its stdout (it exited).
        std::thread::spawn({
            let latest = Arc::clone(&latest);
            move || {
                for line in lines.lines().map_while(Result::ok) {
                    if let Some(observed) = parse(&line) {
                        *latest.lock().unwrap_or_else(|p| p.into_inner()) = Some(observed);
                    }
                }
            }
        });
        Firmware { child, stdin, path, latest, _chip: chip }
    }

    /// One of the harness's state lines.
    fn parse(line: &str) -> Option<Observed> {
        let v: Value = serde_json::from_str(line).ok()?;
        let array = |key: &str, i: usize| v[key][i].as_f64();
        Some(Observed {
            t_ms: v["t_ms"].as_f64()?,
            duty_permille: [array("duty_permille", 0)?, array("duty_permille", 1)?, array("duty_permille", 2)?]
                .map(|d| d as i32),
            pumps: [array("pumps", 0)? != 0.0, array("pumps", 1)? != 0.0],
            lengths_um: [array("lengths_um", 0)?, array("lengths_um", 1)?, array("lengths_um", 2)?],
        })
    }

    impl Target for Firmware {
        fn path(&self) -> &Path {
            &self.path
        }

        fn kind(&self) -> DeviceKind {
            DeviceKind::MEGA
        }

        fn observe(&self) -> Observed {
            let end = Instant::now() + Duration::from_secs(5);
            loop {
                if let Some(observed) = *self.latest.lock().unwrap_or_else(|p| p.into_inner()) {
                    return observed;
                }
                assert!(Instant::now() < end, "leech-simavr sent no state line");
                std::thread::sleep(Duration::from_millis(5));
            }
        }
    }

    impl Drop for Firmware {
        fn drop(&mut self) {
            // Closing its stdin ends the harness; a kill if it does not.
            drop(self.stdin.take());
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
}
