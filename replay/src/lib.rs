//! Lewis replay: reading MCAP recordings, deterministic re-simulation in lockstep,
//! fault injection, comparison reports and live playback.
//!
//! So far: [`info`], what a recording holds (`lewis info`), and [`json`], decoded values
//! as JSON.

pub mod import;
pub mod info;
pub mod json;

pub use info::{InfoError, InfoOptions, InfoReport, inspect};
pub use json::JsonValue;
