//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.

mod dynamic_never_panics;
mod lockstep;
mod mission;
mod ros2_recordings;
mod same_bytes;
mod sweep;
