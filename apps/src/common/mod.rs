//! What every program shares: the building's axes, exit codes, the Mover client, the staleness watch, frames,
//! and the driver of the moving programs.

pub mod axes;
pub mod driver;
pub mod exit;
pub mod frames;
pub mod mover;
pub mod watch;
