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

use std::path::Path;

use lewis_runtime::robot::{self, Known, Robot, RobotError};
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

/// Reads a robot file and checks it whole before anything starts: its syntax, its
/// interfaces, and each service's kind and parameters against [`registry`].
///
/// # Errors
/// [`RobotError::Read`] when the file cannot be read; [`RobotError::Invalid`] with every
/// problem at its `file:line:column` otherwise.
pub fn load_robot(path: &Path) -> Result<Robot, RobotError> {
    let interfaces: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    let registry = registry();
    let known = Known {
        interfaces: &interfaces,
        kinds: Some(&registry),
    };
    robot::load_checked(path, known)
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

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_kind_checks_its_parameters_when_a_robot_file_is_loaded() {
        assert_eq!(
            registry().kinds_without_parameter_check(),
            Vec::<&str>::new()
        );
    }

    #[test]
    fn every_shipped_robot_file_loads_checked() {
        let robots = Path::new(env!("CARGO_MANIFEST_DIR")).join("../robots");
        let mut loaded = 0;
        for entry in std::fs::read_dir(&robots).into_iter().flatten().flatten() {
            let path = entry.path();
            if path.extension().is_some_and(|e| e == "toml") {
                if let Err(e) = load_robot(&path) {
                    panic!("{e}");
                }
                loaded += 1;
            }
        }
        assert!(
            loaded >= 5,
            "found {loaded} robot files in {}",
            robots.display()
        );
    }
}
