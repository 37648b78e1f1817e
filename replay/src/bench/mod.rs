//! Measures of replay, run by hand (`lewis bench ...`), never by the tests:
//!
//! - [`speed`]: how many times faster than real time a recording replays, beside the
//!   lockstep harness alone and the same services called directly in a loop with the
//!   same inputs (the harness's overhead).
//! - [`long`]: a long recording made by looping a short one, to measure the memory of a
//!   replay of a gigabyte.
//! - [`closed`]: a whole mission lived again (`lewis replay --all`) as a multiple of real
//!   time, beside its services' and programs' own handlers, its peak memory, and a sweep.

pub mod closed;
pub mod long;
pub mod speed;
