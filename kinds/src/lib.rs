//! The service registry: every service kind of the component crates, by the name robot files
//! give it (`kind = "..."`), with its role in a replay (which are devices, which simulated).
//! `lewis service`, `lewis replay` and the replay benchmark build their services from it; a
//! team's own binary adds its kinds to it (`lewis::main_with`).
//!
//! It owns no service: the simulator's are in `lewis-sim`, the drivers' in `lewis-drivers`,
//! motion's in `lewis-motion`, perception's in `lewis-perception`, the live ROS 2 gateway's
//! in `lewis-ros2` (feature `ros2`, on by default), and the test service
//! `test-range` and the emulated B21r's camera `emulated-camera` in `lewis-emulators`
//! (registered here too, so that a robot file such as `robots/test.toml` or
//! `robots/b21r-emulated.toml` runs and replays through the same registry as any other).

use lewis_service::ServiceRegistry;

/// Every service kind of Lewis, registered with its parameters and its role: what `lewis
/// service`, `lewis replay` and the replay benchmark build services from.
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
    #[cfg(feature = "ros2")]
    lewis_ros2::register(&mut registry);
    registry
}

#[cfg(test)]
mod tests {
    use std::path::Path;

    use lewis_service::Role;

    use super::*;

    #[test]
    fn the_devices_and_the_simulated_devices_are_the_sources_replay_feeds() {
        let registry = registry();
        let kinds = |role| {
            registry
                .kinds()
                .into_iter()
                .filter(|kind| registry.role(kind) == Some(role))
                .collect::<Vec<_>>()
        };
        let mut devices = vec![
            "camera",
            "emulated-camera",
            "espeak-speech",
            "rflex",
            "sick",
        ];
        #[cfg(feature = "ros2")]
        devices.extend(lewis_ros2::KINDS);
        devices.sort_unstable();
        assert_eq!(kinds(Role::Device), devices);
        assert_eq!(
            kinds(Role::SimulatedDevice),
            [
                "sim-base",
                "sim-camera",
                "sim-laser",
                "sim-sonar",
                "sim-speech",
                "test-range"
            ]
        );
        assert_eq!(registry.source_kinds().len(), devices.len() + 6);
    }

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
                if let Err(e) = registry().load_robot(&path) {
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
