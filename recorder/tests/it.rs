//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.
//! Own binaries (see `Cargo.toml`): `crash`.

mod common;
mod errors;
mod files;
mod queue;
mod recover;
