//! Lewis beyond one machine: the hosts of a robot (`[[hosts]]` in its robot file) as one
//! system over Zenoh.
//!
//! Inside a host, services talk through iceoryx2's shared memory as ever. Between hosts,
//! each host's bridge carries what its clients need ([`routes`]) as the same CDR bytes on
//! Zenoh keys named after the channels ([`keys`]), and the robot host's broker decides for
//! the whole robot: it starts and stops the other hosts' services through their own
//! supervisors ([`RobotHost`], implementing the runtime's `RemoteHosts`), and fails their
//! services over when a host goes away ([`run_host`] is the other hosts' side).
//!
//! **Architecture invariant:** only this crate knows Zenoh.

mod error;
mod forward;
mod heard;
mod imported;
pub mod keys;
mod other_host;
mod robot_host;
pub mod routes;
mod schemas;
pub mod session;
pub mod wire;

pub use error::BridgeError;
pub use forward::{BRIDGE_NODE, ForwardOptions, Forwarder};
pub use heard::Heard;
pub use other_host::{HostOptions, run_host};
pub use robot_host::RobotHost;
pub use schemas::Schemas;
