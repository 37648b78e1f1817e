//! Test services that need no hardware, for the failover tests and demonstrations:
//!
//! - [`range`]: `test-range`, a range finder that publishes a synthetic scan of a
//!   rectangular room (RangeFinder and Distance) at a rate, and can be told to crash, stall
//!   or go out of service through a fault file, so that tests decide exactly when.

pub mod range;

use lewis_service::{Role, ServiceRegistry};

/// Registers the test service kinds (`test-range`).
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<range::Params>(range::KIND, range::build);
    // Synthetic ranges of a room from a seed: as re-runnable as the simulator.
    registry.set_role(range::KIND, Role::SimulatedDevice);
}
