//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.

mod heartbeats;
mod ipc_cross_process;
mod ipc_in_process;
mod program;
mod supervise;
