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
    /// Blocks (or frees) the motor of tube `tube` (0..=2).
    fn stall(&self, tube: usize, stalled: bool);
    /// Makes cup `cup` (0 rear, 1 front) leak, so it loses its vacuum (or
    /// seals it again).
    fn leak(&self, cup: usize, leaking: bool);
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

    fn stall(&self, tube: usize, stalled: bool) {
        let mut faults = self.with_sim(|sim| sim.faults());
        faults.stalled[tube] = stalled;
        self.set_faults(faults);
    }

    fn leak(&self, cup: usize, leaking: bool) {
        let mut faults = self.with_sim(|sim| sim.faults());
        faults.vacuum_loss[cup] = leaking;
        self.set_faults(faults);
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
    //! The firmware on `leech-simavr` ([`leech_link::chip`]), built once per
    //! test run into this test binary's scratch directory. One chip runs at
    //! a time: the simulator keeps real time only with a core to itself on
    //! a 2-core machine.

    use std::path::Path;
    use std::sync::{Mutex, MutexGuard};
    use std::time::Duration;

    use leech_link::chip::{self, Built, Chip};
    use leech_protocol::message::DeviceKind;

    use super::{Observed, Target};

    fn built() -> &'static Built {
        let out = Path::new(env!("CARGO_TARGET_TMPDIR")).join("firmware");
        chip::build_once(&out).unwrap_or_else(|e| panic!("{e}"))
    }

    /// The firmware on its chip, one at a time (module doc).
    pub struct Firmware {
        chip: Chip,
        _one_at_a_time: MutexGuard<'static, ()>,
    }

    /// The firmware, just started.
    pub fn firmware() -> Firmware {
        static CHIP: Mutex<()> = Mutex::new(());
        let built = built();
        let guard = CHIP.lock().unwrap_or_else(|poisoned| poisoned.into_inner());
        Firmware { chip: Chip::spawn(built).unwrap_or_else(|e| panic!("{e}")), _one_at_a_time: guard }
    }

    impl Target for Firmware {
        fn path(&self) -> &Path {
            self.chip.path()
        }

        fn kind(&self) -> DeviceKind {
            DeviceKind::MEGA
        }

        fn observe(&self) -> Observed {
            let state = self.chip.observe(Duration::from_secs(5)).expect("leech-simavr reports its state");
            Observed {
                t_ms: state.t_ms,
                duty_permille: state.duty_permille,
                pumps: state.pumps.map(|p| p != 0),
                lengths_um: state.lengths_um,
            }
        }

        fn stall(&self, tube: usize, stalled: bool) {
            let verb = if stalled { "stall" } else { "free" };
            self.chip.harness(&format!("{verb} {tube}")).expect("the harness takes a command");
        }

        fn leak(&self, cup: usize, leaking: bool) {
            let verb = if leaking { "vacuum-loss" } else { "seal" };
            self.chip.harness(&format!("{verb} {cup}")).expect("the harness takes a command");
        }
    }
}
