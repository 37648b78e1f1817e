//! Stand-ins for hardware, for `lewis fake-device` and for tests: the SICK scanner and the
//! RFlex base behind pseudo-terminals, fed by the simulated world, and the test services.
//!
//! - [`FakeSick`] and [`FakeRflex`]: the devices' state machines of `lewis-drivers` behind a
//!   pseudo-terminal, on a thread driven by `poll` (no busy waiting), with fault injection
//!   ([`parse_faults`]) and unplugging. Linux only: they read the host's baud rate from the
//!   pseudo-terminal's termios (`TCGETS2` on the master reflects the slave's settings), at
//!   every read; what that can and cannot tell is in [`fake_device`].
//! - [`Standalone`] (`lewis fake-device`): a device on a pseudo-terminal that a real driver
//!   opens, its readings ray cast in a world of `lewis-sim` ([`WorldLaserSource`],
//!   [`WorldSonarSource`]) or in a bare room; emulators of one robot in two processes share
//!   the base's true pose through a file ([`pose_file`]).
//! - [`camera`]: `emulated-camera`, the simulator's camera rendering from that shared pose,
//!   so that a robot of emulated devices sees the world's signs too.
//! - [`testing`]: `test-range`, the service the failover tests and demonstrations run.
//!
//! Nothing in the production drivers depends on this crate: only the registry (for
//! `test-range` and `emulated-camera`), the `lewis` binary and tests do. Only the emulators
//! read the pose file (the laser's, and `emulated-camera`): the drivers, perception, motion
//! and the programs never do.

pub mod camera;
mod clock;
pub mod fake_device;
mod fault_spec;
pub mod pose_file;
mod pty;
pub mod standalone;
pub mod testing;
mod world_source;

pub use clock::MonotonicClock;
pub use fake_device::{
    Emulated, EmulatorStats, FakeDevice, FakeDeviceError, FakeRflex, FakeSick, HostRates,
    RflexEmulation, RflexEmulatorOptions, SickEmulation,
};
pub use fault_spec::{FAULT_SYNTAX, FaultPlan, FaultSpecError, Unplug, parse_faults};
pub use pose_file::{POSE_FILE_NAME, PoseFile, PoseFileError};
pub use pty::{Pty, PtyError};
pub use standalone::{DeviceKind, Standalone, StandaloneError, StandaloneOptions};
pub use world_source::{PoseFeed, PoseFileFeed, SharedPose, WorldLaserSource, WorldSonarSource};
