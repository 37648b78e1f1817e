//! The emulators as `lewis fake-device` runs them: one device on its own pseudo-terminal,
//! seeing either a world of the simulator or, without one, a plain room.
//!
//! Without a world the scanner sees the 6 m by 4 m room of `test-range` from its centre line
//! ([`Room::DEFAULT`]), and the base's sonar ring sees the same room around it wherever the
//! base has driven (the room moves with it: this is a line check, not a simulation). With a
//! world, the base drives through it from `start` with its sonar seeing what the simulator's
//! sonar would, and the scanner sees the world from `start`; given a robot-state directory
//! (the same for both processes), the base writes its true pose there ([`PoseFile`]) as it
//! moves and the scanner renders from the latest one, so its ranges follow the drive.
//!
//! Faults come from a [`FaultPlan`]: the device's from the start, and the cable pulled and
//! put back at the plan's times.

use std::path::PathBuf;
use std::sync::Arc;

use lewis_drivers::rflex::RflexDeviceConfig;
use lewis_drivers::sick::{ScanLayout, SickDeviceConfig};
use lewis_geometry::{Pose2, b21r_sonar_ring};
use lewis_sim::{self as sim, LaserConfig, SimSonar, SonarConfig, World};

use crate::fake_device::{FakeDeviceError, FakeRflex, FakeSick, RflexEmulatorOptions};
use crate::fault_spec::FaultPlan;
use crate::pose_file::{PoseFile, PoseFileError};
use crate::testing::range::Room;
use crate::world_source::{PoseFileFeed, SharedPose, WorldLaserSource, WorldSonarSource};

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
    /// Faults, and when the cable is pulled.
    pub faults: FaultPlan,
    /// A world folder of the simulator to see (`None`: the plain room).
    pub world: Option<PathBuf>,
    /// Where the robot stands in the world.
    pub start: Pose2,
    /// A directory shared by the base's and the laser's emulators, where the base writes its
    /// true pose and the laser reads it (with a world only).
    pub robot_state: Option<PathBuf>,
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
    /// The robot-state directory is given without a world to move in.
    #[error("--robot-state shares the robot's pose in a world: give --world too")]
    RobotStateWithoutWorld,
    /// The robot-state directory cannot be used.
    #[error(transparent)]
    RobotState(#[from] PoseFileError),
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
        let pose_file = match (&options.robot_state, &world) {
            (Some(_), None) => return Err(StandaloneError::RobotStateWithoutWorld),
            (Some(dir), Some(_)) => Some(PoseFile::in_dir(dir)),
            (None, _) => None,
        };
        let link = options.link.as_deref();
        let faults = options.faults.faults;
        let started = match kind {
            DeviceKind::Sick => {
                let config = SickDeviceConfig {
                    faults,
                    ..SickDeviceConfig::default()
                };
                let fake = match (world, pose_file) {
                    (Some(world), Some(file)) => FakeSick::start(
                        config,
                        WorldLaserSource::new(
                            world,
                            LaserConfig::default(),
                            options.seed,
                            PoseFileFeed::new(file, options.start),
                        ),
                        link,
                    )?,
                    (Some(world), None) => FakeSick::start(
                        config,
                        WorldLaserSource::new(
                            world,
                            LaserConfig::default(),
                            options.seed,
                            SharedPose::new(options.start),
                        ),
                        link,
                    )?,
                    (None, _) => FakeSick::start(config, room_scan, link)?,
                };
                Self::Sick(fake)
            }
            DeviceKind::Rflex => {
                let config = RflexDeviceConfig {
                    faults,
                    ..RflexDeviceConfig::default()
                };
                let fake = match world {
                    Some(world) => {
                        if let Some(file) = &pose_file {
                            // Fails here, clearly, when the directory cannot be written.
                            file.write(options.start)?;
                        }
                        let sonar = SimSonar::new(SonarConfig::default(), options.seed)?;
                        FakeRflex::start(
                            config,
                            WorldSonarSource::new(world, sonar, options.start),
                            RflexEmulatorOptions {
                                origin: options.start,
                                shared_pose: None,
                                pose_file,
                            },
                            link,
                        )?
                    }
                    None => {
                        FakeRflex::start(config, room_sonar, RflexEmulatorOptions::default(), link)?
                    }
                };
                Self::Rflex(fake)
            }
        };
        match &started {
            Self::Sick(fake) => fake.schedule_unplugs(&options.faults.unplugs),
            Self::Rflex(fake) => fake.schedule_unplugs(&options.faults.unplugs),
        }
        Ok(started)
    }

    /// The path a driver opens.
    #[must_use]
    pub fn path(&self) -> PathBuf {
        match self {
            Self::Sick(fake) => fake.path(),
            Self::Rflex(fake) => fake.path(),
        }
    }

    /// The scanner's emulator, if this is one (tests inspect and steer it).
    #[must_use]
    pub fn sick(&self) -> Option<&FakeSick> {
        match self {
            Self::Sick(fake) => Some(fake),
            Self::Rflex(_) => None,
        }
    }

    /// The base's emulator, if this is one.
    #[must_use]
    pub fn rflex(&self) -> Option<&FakeRflex> {
        match self {
            Self::Rflex(fake) => Some(fake),
            Self::Sick(_) => None,
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
fn room_sonar(_pose: &Pose2) -> Vec<f64> {
    b21r_sonar_ring()
        .iter()
        .map(|mount| {
            let centre_range = Room::DEFAULT.range_at(mount.pose.heading_rad);
            (centre_range - mount.pose.position().norm()).max(0.0)
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
        let sonar = room_sonar(&Pose2::default());
        assert_eq!(sonar.len(), 48);
        assert!(
            (sonar[0] - (4.0 - 0.26)).abs() < 1e-9,
            "ahead: {}",
            sonar[0]
        );
    }
}
