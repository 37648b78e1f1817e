//! Lewis runtime: the service model (`Service`, `Context`), the clock, IPC over
//! iceoryx2, typed clients that follow rebinding, the broker (a pure decision core and
//! its live driver) and process supervision.
//!
//! It knows nothing of MCAP files, recording or replay.

pub mod broker;
pub mod client;
pub mod clock;
pub mod ipc;
pub mod live;
pub mod logs;
pub mod names;
pub mod supervise;
