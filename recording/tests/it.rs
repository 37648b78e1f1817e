//! The integration tests of this crate, one module per file of `tests/`, linked into
//! one test binary: one link instead of one per file.

mod info;
mod play;
mod versions;
