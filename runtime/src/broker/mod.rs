//! The broker: a pure decision core (events in, actions out) and its live driver.
//!
//! The [`BrokerCore`] decides which service provides each interface a client asks for,
//! when to start, restart, stop or replace a provider, and when to ask for help. It does no
//! I/O and reads no clock: time comes in with every event, so the same events give the same
//! decisions live and in replay. The live driver turns processes, heartbeats and timers
//! into [`Event`]s and carries out the [`Action`]s; every [`Decision`] (action and reason)
//! is published on `/lewis/broker`. The [`health`] checks judge what providers publish
//! (rate, freshness, values, a frozen stream), as purely as the core; [`cpu`] measures what
//! a provider's process uses of the CPU, for the core's CPU budget.

mod core;
pub mod cpu;
pub mod health;
mod host_link;
pub mod live;
pub mod remote;
pub mod status;

pub use self::core::{
    Action, AfterStop, Binding, BrokerCore, Decision, Event, ExitStatus, Need, ServiceState,
    ServiceStatus, Snapshot,
};
