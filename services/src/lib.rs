//! Lewis services: device drivers (SICK laser, RFlex base, camera), the simulator,
//! motion (VectorMover, ObstacleAvoider), perception (BlobFinder, BlobFinder3D,
//! SignDetector) and Distance from any RangeFinder (`range_distance`).
//!
//! Services see only the runtime's `Context`: they know nothing of recording or replay.

pub mod camera;
pub mod drivers;
pub mod motion;
pub mod perception;
pub mod range_distance;
pub mod sim;
pub mod testing;

use lewis_runtime::service::ServiceRegistry;

/// Every service kind of this crate, registered: what `lewis service`, `lewis replay` and the
/// replay benchmark build services from.
#[must_use]
pub fn registry() -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    testing::register(&mut registry);
    drivers::service::register(&mut registry);
    sim::service::register(&mut registry);
    motion::service::register(&mut registry);
    perception::register(&mut registry);
    range_distance::register(&mut registry);
    registry
}

/// The kinds that talk to a device or to the simulated world: a replay feeds them from the
/// recording by default, even when they require something (the simulated sensors require
/// GroundTruth).
pub const SOURCE_KINDS: &[&str] = &[
    sim::service::base::KIND,
    sim::service::laser::KIND,
    sim::service::sonar::KIND,
    sim::service::camera::KIND,
    drivers::service::sick::KIND,
    drivers::service::rflex::KIND,
    camera::KIND,
    testing::range::KIND,
];
