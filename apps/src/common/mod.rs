//! What every program shares: exit codes, the Mover client, the staleness watch, frames.

pub mod exit;
pub mod frames;
pub mod mover;
pub mod watch;
