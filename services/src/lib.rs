//! The service registry: every service kind of the component crates, by the name robot files
//! give it (`kind = "..."`), and which of them are sources. `lewis service`, `lewis replay` and
//! the replay benchmark build their services from it.
//!
//! It owns no service: the simulator's are in `lewis-sim`, the drivers' in `lewis-drivers`,
//! motion's in `lewis-motion`, perception's in `lewis-perception`, and the test service
//! `test-range` in `lewis-emulators` (registered here too, so that a robot file such as
//! `robots/test.toml` runs and replays through the same registry as any other).

use lewis_runtime::service::ServiceRegistry;

/// Every service kind, registered: what `lewis service`, `lewis replay` and the replay
/// benchmark build services from.
#[must_use]
pub fn registry() -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    lewis_emulators::testing::register(&mut registry);
    lewis_drivers::service::register(&mut registry);
    lewis_sim::service::register(&mut registry);
    lewis_motion::service::register(&mut registry);
    lewis_drivers::camera::register(&mut registry);
    lewis_perception::register(&mut registry);
    registry
}

/// The kinds that talk to a device or to the simulated world: a replay feeds them from the
/// recording by default, even when they require something (the simulated sensors require
/// GroundTruth).
pub const SOURCE_KINDS: &[&str] = &[
    lewis_sim::service::base::KIND,
    lewis_sim::service::laser::KIND,
    lewis_sim::service::sonar::KIND,
    lewis_sim::service::camera::KIND,
    lewis_drivers::service::sick::KIND,
    lewis_drivers::service::rflex::KIND,
    lewis_drivers::camera::KIND,
    lewis_emulators::testing::range::KIND,
];
