//! Range sources backed by the simulator's world, so that the emulators see what the simulated
//! laser and sonar would: the base's emulator moves its true pose through the world, and the
//! laser's emulator reads that pose ([`PoseFeed`]): through a [`SharedPose`] in one process,
//! or through the [`PoseFile`] that the base's emulator writes when they are two processes.

use std::sync::{Arc, Mutex, PoisonError};

use super::pose_file::PoseFile;
use lewis_drivers::rflex::SonarSource;
use lewis_drivers::sick::{RangeSource, ScanLayout};
use lewis_geometry::Pose2;
use lewis_sim::{LaserConfig, SimLaser, SimSonar, World};

/// A pose written by one emulator (the base) and read by another (the laser).
#[derive(Debug, Clone, Default)]
pub struct SharedPose(Arc<Mutex<Pose2>>);

impl SharedPose {
    /// A shared pose starting at `pose`.
    pub fn new(pose: Pose2) -> Self {
        Self(Arc::new(Mutex::new(pose)))
    }

    /// The pose now.
    pub fn get(&self) -> Pose2 {
        *self.0.lock().unwrap_or_else(PoisonError::into_inner)
    }

    /// Moves the pose.
    pub fn set(&self, pose: Pose2) {
        *self.0.lock().unwrap_or_else(PoisonError::into_inner) = pose;
    }
}

/// Where a world-backed laser learns the robot's true pose at each scan.
pub trait PoseFeed: std::fmt::Debug {
    /// The robot's world pose now.
    fn pose(&mut self) -> Pose2;
}

impl PoseFeed for SharedPose {
    fn pose(&mut self) -> Pose2 {
        self.get()
    }
}

/// The pose that another process's base emulator writes to a [`PoseFile`]; until it has
/// written one (and whenever the file cannot be read), the last pose known, at first
/// `start`.
#[derive(Debug, Clone)]
pub struct PoseFileFeed {
    file: PoseFile,
    last: Pose2,
}

impl PoseFileFeed {
    /// Reads `file`, assuming `start` until there is a pose in it.
    pub fn new(file: PoseFile, start: Pose2) -> Self {
        Self { file, last: start }
    }
}

impl PoseFeed for PoseFileFeed {
    fn pose(&mut self) -> Pose2 {
        // The writer replaces the file atomically: an error is a file not written yet or
        // removed, and the last pose is the best guess.
        if let Ok(Some(pose)) = self.file.read() {
            self.last = pose;
        }
        self.last
    }
}

/// Laser ranges from the world at the robot's pose: a [`SimLaser`] with the scanner's current
/// angle and resolution (rebuilt when they change), its mount, noise and range from `config`.
#[derive(Debug)]
pub struct WorldLaserSource {
    world: Arc<World>,
    config: LaserConfig,
    seed: u64,
    pose: Box<dyn PoseFeed + Send>,
    laser: Option<(ScanLayout, SimLaser)>,
}

impl WorldLaserSource {
    /// A source seeing `world` from `pose` (the robot's, the laser's mount is in `config`).
    /// `config`'s beam count and field of view are replaced by the scanner's layout.
    pub fn new(
        world: Arc<World>,
        config: LaserConfig,
        seed: u64,
        pose: impl PoseFeed + Send + 'static,
    ) -> Self {
        Self {
            world,
            config,
            seed,
            pose: Box::new(pose),
            laser: None,
        }
    }
}

impl RangeSource for WorldLaserSource {
    fn ranges_m(&mut self, layout: ScanLayout) -> Vec<f64> {
        if self
            .laser
            .as_ref()
            .is_none_or(|(built, _)| *built != layout)
        {
            let config = LaserConfig {
                beam_count: layout.value_count(),
                field_of_view_rad: f64::from(layout.width.degrees()).to_radians(),
                ..self.config
            };
            // A config the simulator refuses leaves no laser: the scan reads "nothing seen".
            self.laser = SimLaser::new(config, self.seed)
                .ok()
                .map(|laser| (layout, laser));
        }
        let Some((_, laser)) = &mut self.laser else {
            return Vec::new();
        };
        laser.scan(&self.world, self.pose.pose()).ranges
    }
}

/// Sonar ranges from the world: a [`SimSonar`] at the base's true pose placed at `origin`.
#[derive(Debug)]
pub struct WorldSonarSource {
    world: Arc<World>,
    sonar: SimSonar,
    origin: Pose2,
}

impl WorldSonarSource {
    /// A source seeing `world` with `sonar`, the base's odometry origin at world pose `origin`.
    pub fn new(world: Arc<World>, sonar: SimSonar, origin: Pose2) -> Self {
        Self {
            world,
            sonar,
            origin,
        }
    }
}

impl SonarSource for WorldSonarSource {
    fn ranges_m(&mut self, pose: &Pose2) -> Vec<f64> {
        let world_pose = self.origin.compose(*pose);
        self.sonar.scan(&self.world, world_pose).ranges
    }
}
