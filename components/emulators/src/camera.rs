//! `emulated-camera`: the simulator's camera for a robot whose base and laser are emulated
//! (`lewis fake-device rflex|sick --world DIR --robot-state STATE`), so that the programs see
//! the world's signs and coloured objects from where the emulated base really is.
//!
//! Without the simulator nobody publishes GroundTruth: the base's emulator shares the robot's
//! true pose through the [`PoseFile`] in its robot-state directory, which the laser's emulator
//! renders its scans from. This service renders the camera's frames from the same pose, with
//! the `sim-camera` model and services (ImageSource, CameraControl): the same parameters, plus
//! `robot_state`, the directory given to the emulators. It is an emulation facility, like
//! the fake devices: nothing of a real robot (its drivers, perception, motion, the programs)
//! reads the pose file. The people stand where the world file puts them (no WorldState).
//!
//! ```toml
//! [services.parameters]
//! robot_state = "/tmp/lewis-b21r"
//! world = "robots/worlds/conference"
//! seed = 4
//! rate_hz = 5.0
//! width_px = 640
//! height_px = 480
//! horizontal_fov_deg = 48.8
//! mount = { x_m = 0.1, y_m = 0.0, heading_deg = 0.0, height_m = 1.2 }
//! ```

use std::path::PathBuf;

use lewis_geometry::Pose2;
use lewis_service::{BuildError, Role, Service, ServiceConfig, ServiceRegistry};
use lewis_sim::service::{CameraParams, SimCameraService, TruePoseSource};
use serde::{Deserialize, Deserializer};

use crate::pose_file::PoseFile;

/// The kind name in robot files.
pub const KIND: &str = "emulated-camera";

/// Registers `emulated-camera`.
pub fn register(registry: &mut ServiceRegistry) {
    registry.register_with_parameters::<EmulatedCameraParams>(KIND, build);
    registry.set_role(KIND, Role::Device);
}

/// The parameters of `emulated-camera`: `sim-camera`'s, and the emulators' robot-state
/// directory.
#[derive(Debug, Clone, PartialEq)]
pub struct EmulatedCameraParams {
    /// The directory the base's emulator writes the true pose in (`--robot-state`).
    pub robot_state: PathBuf,
    /// The camera, as `sim-camera` takes it.
    pub camera: CameraParams,
}

impl<'de> Deserialize<'de> for EmulatedCameraParams {
    /// One flat table, as `sim-camera`'s with `robot_state` added. Written out rather than
    /// with `#[serde(flatten)]`, which cannot deny unknown fields: the camera's parameters
    /// keep their checks and their list of expected names (the did-you-mean hint).
    fn deserialize<D: Deserializer<'de>>(deserializer: D) -> Result<Self, D::Error> {
        use serde::de::Error as _;
        let mut table = toml::Table::deserialize(deserializer)?;
        let robot_state = table
            .remove("robot_state")
            .ok_or_else(|| D::Error::missing_field("robot_state"))?;
        let robot_state = PathBuf::deserialize(robot_state)
            .map_err(|e| D::Error::custom(format!("robot_state: {}", e.message())))?;
        let camera = CameraParams::deserialize(toml::Value::Table(table))
            .map_err(|e| D::Error::custom(e.message()))?;
        Ok(Self {
            robot_state,
            camera,
        })
    }
}

/// Builds an `emulated-camera` service from its robot-file entry.
///
/// # Errors
/// When a parameter is missing, unknown or cannot work, or the world does not load.
pub fn build(config: &ServiceConfig<'_>) -> Result<Box<dyn Service>, BuildError> {
    let params: EmulatedCameraParams = config.parameters()?;
    let truth = PoseFileTruth {
        file: PoseFile::in_dir(&params.robot_state),
        last: None,
    };
    Ok(Box::new(SimCameraService::with_true_pose(
        config,
        &params.camera,
        Box::new(truth),
    )?))
}

/// The true pose the base's emulator writes, read at every frame.
#[derive(Debug)]
struct PoseFileTruth {
    file: PoseFile,
    /// The last pose read.
    last: Option<Pose2>,
}

impl TruePoseSource for PoseFileTruth {
    fn true_pose(&mut self) -> Result<Option<Pose2>, String> {
        match self.file.read() {
            Ok(Some(pose)) => {
                self.last = Some(pose);
                Ok(self.last)
            }
            // Gone after it was there: the base's emulator stopped; where it left the
            // robot is still where the robot is.
            Ok(None) if self.last.is_some() => Ok(self.last),
            Ok(None) => Err(format!(
                "{} does not exist: start the base's emulator first, \
                 `lewis fake-device rflex --world DIR --robot-state {}`",
                self.file.path().display(),
                self.file
                    .path()
                    .parent()
                    .map_or_else(String::new, |dir| dir.display().to_string()),
            )),
            Err(e) => Err(e.to_string()),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn params(text: &str) -> Result<EmulatedCameraParams, String> {
        toml::from_str::<toml::Table>(text)
            .unwrap()
            .try_into()
            .map_err(|e: toml::de::Error| e.message().to_owned())
    }

    #[test]
    fn parameters_are_the_sim_cameras_and_the_robot_state_directory() {
        let read = params(
            "robot_state = \"/tmp/state\"\nworld = \"robots/worlds/conference\"\nrate_hz = 5.0\n",
        )
        .unwrap();
        assert_eq!(read.robot_state, PathBuf::from("/tmp/state"));
        assert_eq!(read.camera.world, PathBuf::from("robots/worlds/conference"));
        assert!((read.camera.rate_hz - 5.0).abs() < 1e-12);

        let missing = params("world = \"w\"\n").unwrap_err();
        assert!(missing.contains("robot_state"), "{missing}");
        let misspelt =
            params("robot_state = \"s\"\nworld = \"w\"\nmax_rnage_m = 3.0\n").unwrap_err();
        assert!(
            misspelt.contains("unknown field `max_rnage_m`") && misspelt.contains("`max_range_m`"),
            "{misspelt}"
        );
    }

    #[test]
    fn the_pose_is_the_files_and_stays_the_last_one_once_the_file_is_gone() {
        let dir = tempfile::tempdir().unwrap();
        let file = PoseFile::in_dir(dir.path());
        let mut truth = PoseFileTruth {
            file: file.clone(),
            last: None,
        };
        let error = truth.true_pose().unwrap_err();
        assert!(
            error.contains("true-pose") && error.contains("lewis fake-device rflex"),
            "{error}"
        );
        let pose = Pose2::new(3.0, 12.5, 0.25);
        file.write(pose).unwrap();
        assert_eq!(truth.true_pose(), Ok(Some(pose)));
        std::fs::remove_file(file.path()).unwrap();
        assert_eq!(truth.true_pose(), Ok(Some(pose)));
        std::fs::write(file.path(), "nonsense\n").unwrap();
        assert!(truth.true_pose().unwrap_err().contains("nonsense"));
    }
}
