//! Device drivers: the serial protocols of the SICK laser and the RFlex base.
//!
//! This layer is pure: codecs (frame, parse, CRC or checksum), streaming deframers that
//! resynchronise after garbage, and the device-side state machines used by the emulators.
//! It opens no port, starts no thread and reads no clock: time is passed in as nanoseconds.
//! The exceptions are [`io`] (ports, pseudo-terminals, the emulators' threads) and
//! [`service`] (the `sick` and `rflex` service kinds built on `io`).

pub mod faults;
pub mod framing;
pub mod io;
pub mod rflex;
pub mod service;
pub mod sick;
