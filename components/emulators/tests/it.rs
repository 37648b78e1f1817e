//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.

mod emulated_camera;
mod pty_common;
mod pty_port;
mod pty_rflex;
mod pty_sick;
