//! The device drivers: the SICK laser and the RFlex base over serial ports, and the camera
//! (image sequences and V4L2 video devices), each as a service kind (`sick`, `rflex`,
//! `camera`); and the robot's voice through espeak-ng (`espeak-speech`, [`speech`]).
//!
//! In layers:
//!
//! - [`sick`], [`rflex`], [`framing`], [`faults`]: the protocols as pure code: codecs (frame,
//!   parse, CRC or checksum), streaming deframers that resynchronise after garbage, and the
//!   devices' side as state machines (the emulators' core, and the other end of the
//!   conversation tests). No port, no thread, no clock: time is passed in as nanoseconds.
//! - [`io`]: ports and the host-side drivers (health, reconnection, the SICK's reader thread).
//! - [`service`] and [`camera`]: the service kinds, adapting the drivers to the runtime's
//!   `Service` trait.
//!
//! It does not know the simulator: where a driver needs shared vocabulary (poses, mounts,
//! sector layouts, Distance) it takes it from `lewis-geometry`, and image files and
//! intrinsics from `lewis-images`. The emulators that play a device on a pseudo-terminal
//! are in `lewis-emulators`.

pub mod camera;
pub mod faults;
pub mod framing;
pub mod io;
pub mod rflex;
pub mod service;
pub mod sick;
pub mod speech;
