//! The service registry: every service kind of the component crates, by the name robot files
//! give it (`kind = "..."`), and which of them are sources. `lewis service`, `lewis replay` and
//! the replay benchmark build their services from it.
//!
//! It owns no service: the simulator's are in `lewis-sim`, the drivers' in `lewis-drivers`,
//! motion's in `lewis-motion`, perception's in `lewis-perception`, and the test service
//! `test-range` and the emulated B21r's camera `emulated-camera` in `lewis-emulators`
//! (registered here too, so that a robot file such as `robots/test.toml` or
//! `robots/b21r-emulated.toml` runs and replays through the same registry as any other).

use std::path::Path;

use lewis_robot::{Known, Robot, RobotError};
use lewis_service::ServiceRegistry;

/// Every service kind, registered: what `lewis service`, `lewis replay` and the replay
/// benchmark build services from.
#[must_use]
pub fn registry() -> ServiceRegistry {
    let mut registry = ServiceRegistry::new();
    lewis_emulators::testing::register(&mut registry);
    lewis_emulators::camera::register(&mut registry);
    lewis_drivers::service::register(&mut registry);
    lewis_sim::service::register(&mut registry);
    lewis_motion::service::register(&mut registry);
    lewis_drivers::camera::register(&mut registry);
    lewis_drivers::speech::register(&mut registry);
    lewis_perception::register(&mut registry);
    registry
}

/// Reads a robot file and checks it whole before anything starts: its syntax, its
/// interfaces, and each service's kind and parameters against [`registry`].
///
/// # Errors
/// [`RobotError::Read`] when the file cannot be read; [`RobotError::Invalid`] with every
/// problem at its `file:line:column` otherwise.
pub fn load_robot(path: &Path) -> Result<Robot, RobotError> {
    let interfaces = lewis_interfaces::interface_names();
    let registry = registry();
    let known = Known {
        interfaces: &interfaces,
        kinds: Some(&registry),
    };
    lewis_robot::load_checked(path, known)
}

/// The kinds that talk to a device or to the simulated world: a replay feeds them from the
/// recording by default, even when they require something (the simulated sensors require
/// GroundTruth).
pub const SOURCE_KINDS: &[&str] = &[
    lewis_sim::service::base::KIND,
    lewis_sim::service::laser::KIND,
    lewis_sim::service::sonar::KIND,
    lewis_sim::service::camera::KIND,
    lewis_sim::service::speech::KIND,
    lewis_drivers::service::sick::KIND,
    lewis_drivers::service::rflex::KIND,
    lewis_drivers::camera::KIND,
    lewis_drivers::speech::KIND,
    lewis_emulators::testing::range::KIND,
    lewis_emulators::camera::KIND,
];

/// The source kinds that are simulated devices: `lewis replay --all` re-runs them
/// from the recorded world and seeds, so the world reacts to what the robot does (the
/// others talk to hardware, or to an emulator of it, and are fed from the recording).
pub const SIMULATED_KINDS: &[&str] = &[
    lewis_sim::service::base::KIND,
    lewis_sim::service::laser::KIND,
    lewis_sim::service::sonar::KIND,
    lewis_sim::service::camera::KIND,
    lewis_sim::service::speech::KIND,
    // Synthetic ranges of a room from a seed: as re-runnable as the simulator.
    lewis_emulators::testing::range::KIND,
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
