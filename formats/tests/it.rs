//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.

mod carmen;
mod carmen_never_panics;
mod ros2_never_panics;
mod ros2_type_hash;
