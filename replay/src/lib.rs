//! Lewis replay: reading MCAP recordings (through `lewis-mcap`, which owns the reading),
//! deterministic re-simulation in lockstep, fault injection, comparison reports and live
//! playback.
//!
//! - [`info`]: what a recording holds (`lewis info`); [`json`]: decoded values as JSON.
//! - [`recording`]: a recording's files, robot and messages in one total order.
//! - [`lockstep`]: the harness that runs the broker's decision core and services on a
//!   virtual clock, fed from a recording.
//! - [`resim`]: `lewis replay`, the re-simulation of a recording into a new one with a
//!   report ([`report`], [`compare`]) and injected faults ([`fault`]).
//! - [`sweep`]: `lewis replay --sweep-fault`, a fault injected at many times and the
//!   mission's fate at each, as a table, JSON and a PNG plot.
//! - [`play`]: `lewis play`, a recording published into live IPC at its recorded pace.
//! - [`mission_log`]: the sequencer's records read back from a recording;
//!   [`mission_replay`]: `lewis seq replay`, a recorded mission replayed on a script.
//! - [`bench`](mod@bench): measures of replay's speed and memory (`lewis bench`).

pub mod bench;
pub mod compare;
pub mod fault;
pub mod info;
pub mod json;
pub mod lockstep;
pub mod mission_log;
pub mod mission_replay;
pub mod outcome;
pub mod play;
pub mod recording;
pub mod report;
pub mod resim;
pub mod sweep;

pub use info::{InfoError, InfoOptions, InfoReport, inspect};
pub use json::JsonValue;
