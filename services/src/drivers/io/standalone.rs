//! The emulators as `lewis fake-device` runs them: one device on its own pseudo-terminal,
//! seeing either a world of the simulator or, without one, a plain room.
//!
//! Without a world the scanner sees the 6 m by 4 m room of `test-range` from its centre line
//! ([`Room::DEFAULT`]), and the base's sonar ring sees the same room around it wherever the
//! base has driven (the room moves with it: this is a line check, not a simulation). With a
//! world, the scanner sees the world from `start`, and the base drives through it from
//! `start` with its sonar seeing what the simulator's sonar would. Two processes do not share
//! a pose: a world-backed scanner stays at `start` however the base moves.

use std::path::PathBuf;
use std::sync::Arc;

use super::fake_device::{FakeDeviceError, FakeRflex, FakeSick, RflexEmulatorOptions};
use super::world_source::{SharedPose, WorldLaserSource, WorldSonarSource};
use crate::drivers::faults::Faults;
use crate::drivers::rflex::{self, RflexDeviceConfig};
use crate::drivers::sick::{ScanLayout, SickDeviceConfig};
use crate::sim::{self, LaserConfig, SimSonar, SonarConfig, World, b21r_sonar_ring};
use crate::testing::range::Room;

/// Which device to emulate.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum DeviceKind {
    /// The SICK laser.
    Sick,
    /// The RFlex base.
    Rflex,
}

/// How to run a standalone emulator.
#[derive(Debug, Clone, PartialEq)]
pub struct StandaloneOptions {
    /// Where to link the device (`None`: print the slave's own path).
    pub link: Option<PathBuf>,
    /// Faults from the start.
    pub faults: Faults,
    /// A world folder of the simulator to see (`None`: the plain room).
    pub world: Option<PathBuf>,
    /// Where the robot stands in the world.
    pub start: sim::Pose2,
    /// Seed of the simulated noise.
    pub seed: u64,
}

/// Why a standalone emulator could not start.
#[derive(Debug, thiserror::Error)]
pub enum StandaloneError {
    /// The world could not be loaded.
    #[error("cannot load the world {path}: {source}")]
    World {
        /// The folder.
        path: PathBuf,
        /// What went wrong.
        source: sim::WorldError,
    },
    /// The simulated sensor refused its configuration.
    #[error("cannot build the simulated sensor: {0}")]
    Sensor(#[from] sim::SensorConfigError),
    /// The emulator could not start.
    #[error(transparent)]
    Device(#[from] FakeDeviceError),
}

/// A running emulator of either kind.
#[derive(Debug)]
pub enum Standalone {
    /// The SICK laser.
    Sick(FakeSick),
    /// The RFlex base.
    Rflex(FakeRflex),
}

impl Standalone {
    /// Starts the emulator `kind` per `options`.
    ///
    /// # Errors
    /// When the world does not load or the pseudo-terminal cannot be made or linked.
    pub fn start(kind: DeviceKind, options: &StandaloneOptions) -> Result<Self, StandaloneError> {
        let world = options
            .world
            .as_deref()
            .map(|path| {
                World::load(path)
                    .map(Arc::new)
                    .map_err(|source| StandaloneError::World {
                        path: path.to_path_buf(),
                        source,
                    })
            })
            .transpose()?;
        let link = options.link.as_deref();
        match kind {
            DeviceKind::Sick => {
                let config = SickDeviceConfig {
                    faults: options.faults,
                    ..SickDeviceConfig::default()
                };
                let fake = match world {
                    Some(world) => FakeSick::start(
                        config,
                        WorldLaserSource::new(
                            world,
                            LaserConfig::default(),
                            options.seed,
                            SharedPose::new(options.start),
                        ),
                        link,
                    )?,
                    None => FakeSick::start(config, room_scan, link)?,
                };
                Ok(Self::Sick(fake))
            }
            DeviceKind::Rflex => {
                let config = RflexDeviceConfig {
                    faults: options.faults,
                    ..RflexDeviceConfig::default()
                };
                let fake = match world {
                    Some(world) => {
                        let sonar = SimSonar::new(SonarConfig::default(), options.seed)?;
                        FakeRflex::start(
                            config,
                            WorldSonarSource::new(world, sonar, options.start),
                            RflexEmulatorOptions {
                                origin: options.start,
                                shared_pose: None,
                            },
                            link,
                        )?
                    }
                    None => {
                        FakeRflex::start(config, room_sonar, RflexEmulatorOptions::default(), link)?
                    }
                };
                Ok(Self::Rflex(fake))
            }
        }
    }

    /// The path a driver opens.
    #[must_use]
    pub fn path(&self) -> PathBuf {
        match self {
            Self::Sick(fake) => fake.path(),
            Self::Rflex(fake) => fake.path(),
        }
    }

    /// The error that stopped the emulator thread, if it stopped on one.
    #[must_use]
    pub fn failure(&self) -> Option<String> {
        match self {
            Self::Sick(fake) => fake.failure(),
            Self::Rflex(fake) => fake.failure(),
        }
    }

    /// Stops the emulator, closing the port and removing the link.
    ///
    /// # Errors
    /// The error that had stopped the emulator thread, if any.
    pub fn stop(self) -> Result<(), FakeDeviceError> {
        match self {
            Self::Sick(fake) => fake.stop(),
            Self::Rflex(fake) => fake.stop(),
        }
    }
}

/// The room as the scanner sees it from the middle of its centre line.
fn room_scan(layout: ScanLayout) -> Vec<f64> {
    (0..layout.value_count())
        .map(|i| Room::DEFAULT.range_at(layout.angle_rad(i)))
        .collect()
}

/// The room around the sonar ring, wherever the base has gone.
fn room_sonar(_pose: &rflex::Pose2) -> Vec<f64> {
    b21r_sonar_ring()
        .iter()
        .map(|mount| {
            let centre_range = Room::DEFAULT.range_at(mount.pose.heading_rad);
            (centre_range - mount.pose.position().length()).max(0.0)
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_room_is_seen_by_both_devices() {
        let scan = room_scan(ScanLayout::WIDE_HALF_DEGREE);
        assert_eq!(scan.len(), 361);
        assert!((scan[180] - 4.0).abs() < 1e-9, "ahead: {}", scan[180]);
        assert!((scan[0] - 2.0).abs() < 1e-9, "right: {}", scan[0]);
        let sonar = room_sonar(&rflex::Pose2::default());
        assert_eq!(sonar.len(), 48);
        assert!(
            (sonar[0] - (4.0 - 0.26)).abs() < 1e-9,
            "ahead: {}",
            sonar[0]
        );
    }
}
