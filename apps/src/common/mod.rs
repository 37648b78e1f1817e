//! What every program shares: exit codes, the Mover client, the staleness watch, frames,
//! and the driver of the moving programs.

pub mod driver;
pub mod exit;
pub mod frames;
pub mod mover;
pub mod watch;
