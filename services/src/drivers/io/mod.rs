//! The I/O layer of the drivers: device emulators on pseudo-terminals and host-side drivers on
//! serial ports, both built on the pure protocol layer of [`crate::drivers`].
//!
//! This is the only part of the drivers that opens ports, starts threads and reads the
//! monotonic clock. Everything here is a plain struct: the service adapters (and
//! `lewis fake-device`) call them.
//!
//! - [`FakeSick`] and [`FakeRflex`]: the scanner and the base behind a pseudo-terminal, on a
//!   thread driven by `poll` (no busy waiting), with fault injection and unplugging.
//! - [`SickDriver`] and [`RflexDriver`]: the host's side, over the `serialport` crate, with
//!   blocking reads bounded by a timeout, a pollable file descriptor, health reporting and
//!   reconnection when the port comes back.
//! - [`SickReader`]: the SICK driver on its own thread (the `sick` service's device reader),
//!   since setting the scanner up waits for seconds; the RFlex driver never waits long and
//!   runs on the service's thread.
//!
//! Linux only: the emulators read the host's baud rate from the pseudo-terminal's termios
//! (`TCGETS2` on the master reflects the slave's settings), at every read; what that can and
//! cannot tell is in [`fake_device`].

mod cancel;
mod clock;
pub mod fake_device;
mod fault_spec;
mod health;
mod link;
mod port;
pub mod pose_file;
mod pty;
mod receiver;
mod retry;
pub mod rflex_driver;
pub mod sick_driver;
pub mod sick_reader;
pub mod standalone;
mod world_source;

pub use clock::MonotonicClock;
pub use fake_device::{
    Emulated, EmulatorStats, FakeDevice, FakeDeviceError, FakeRflex, FakeSick, HostRates,
    RflexEmulation, RflexEmulatorOptions, SickEmulation,
};
pub use fault_spec::{FAULT_SYNTAX, FaultPlan, FaultSpecError, Unplug, parse_faults};
pub use health::DriverHealth;
pub use port::{LineParity, PortError, open_port};
pub use pose_file::{POSE_FILE_NAME, PoseFile, PoseFileError};
pub use pty::{Pty, PtyError};
pub use receiver::{RflexReceiver, SickReceived, SickReceiver};
pub use rflex_driver::{RflexDriver, RflexDriverConfig, RflexDriverError, RflexEvent, RflexStats};
pub use sick_driver::{
    LaserScan, SetupStep, SickDriver, SickDriverConfig, SickDriverError, SickStats,
};
pub use sick_reader::{
    SCAN_QUEUE, STATUS_QUEUE, SickNews, SickReader, SickReaderError, SickReaderStatus, StatusReport,
};
pub use standalone::{DeviceKind, Standalone, StandaloneError, StandaloneOptions};
pub use world_source::{PoseFeed, PoseFileFeed, SharedPose, WorldLaserSource, WorldSonarSource};
