//! The I/O layer of the drivers: host-side drivers on serial ports, built on the pure
//! protocol layer of this crate ([`crate::sick`], [`crate::rflex`]).
//!
//! This is the only part of the drivers that opens ports, starts threads and reads the
//! monotonic clock. Everything here is a plain struct: the service adapters call them.
//!
//! - [`SickDriver`] and [`RflexDriver`]: the host's side, over the `serialport` crate, with
//!   blocking reads bounded by a timeout, a pollable file descriptor, health reporting and
//!   reconnection when the port comes back.
//! - [`SickReader`]: the SICK driver on its own thread (the `sick` service's device reader),
//!   since setting the scanner up waits for seconds; the RFlex driver never waits long and
//!   runs on the service's thread.
//!
//! The devices' side behind pseudo-terminals (`lewis fake-device`) is in `lewis-emulators`.

mod cancel;
mod health;
mod link;
mod port;
mod receiver;
mod retry;
pub mod rflex_driver;
pub mod sick_driver;
pub mod sick_reader;

pub use health::DriverHealth;
pub use port::{LineParity, PortError, open_port};
pub use receiver::{RflexReceiver, SickReceived, SickReceiver};
pub use rflex_driver::{RflexDriver, RflexDriverConfig, RflexDriverError, RflexEvent, RflexStats};
pub use sick_driver::{
    LaserScan, SetupStep, SickDriver, SickDriverConfig, SickDriverError, SickStats,
};
pub use sick_reader::{
    SCAN_QUEUE, STATUS_QUEUE, SickNews, SickReader, SickReaderError, SickReaderStatus, StatusReport,
};
