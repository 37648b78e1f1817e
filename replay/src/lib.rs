//! Lewis replay: deterministic re-simulation of a recording in lockstep, fault injection,
//! closed loop, comparison reports and fault sweeps. Recordings are read through
//! `lewis-recording`.
//!
//! - [`lockstep`]: the harness that runs the broker's decision core and services on a
//!   virtual clock, fed from a recording.
//! - [`resim`]: `lewis replay`, the re-simulation of a recording into a new one with a
//!   report ([`report`], [`compare`]) and injected faults ([`fault`]).
//! - [`sweep`]: `lewis replay --sweep-fault`, a fault injected at many times and the
//!   mission's fate at each, as a table, JSON and a PNG plot.
//! - [`mission_log`]: the sequencer's records read back from a recording;
//!   [`mission_replay`]: `lewis seq replay`, a recorded mission replayed on a script.
//! - [`bench`](mod@bench): measures of replay's speed and memory (`lewis bench`).

pub mod bench;
pub mod compare;
pub mod fault;
pub mod lockstep;
pub mod mission_log;
pub mod mission_replay;
pub mod outcome;
pub mod report;
pub mod resim;
pub mod sweep;
