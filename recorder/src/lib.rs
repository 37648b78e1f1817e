//! Lewis recorder: the tap that sees every publication and writes it to MCAP, with
//! loss accounting, rotation and recovery of truncated files.
//!
//! Not built yet: this crate holds only what it needs to compile.
