//! The robot's true world pose shared between emulator processes through a small file: the
//! base's emulator writes it as the base moves, the laser's emulator renders its scans from
//! the latest one, so that two `lewis fake-device` processes see one world consistently.
//!
//! The file is replaced atomically (written beside, then renamed over), so a reader sees the
//! old pose or the new one, never half of one. It holds one line of text,
//! `x_m y_m heading_rad`, in the world frame. Only the emulators know it: the drivers and
//! services never read it (a real robot has no such file).

use std::io::Write as _;
use std::path::{Path, PathBuf};

use lewis_geometry::Pose2;

/// The file's name in the shared directory (`--robot-state DIR`).
pub const POSE_FILE_NAME: &str = "true-pose";

/// Why the pose file could not be written or read.
#[derive(Debug, thiserror::Error)]
pub enum PoseFileError {
    /// Writing failed.
    #[error(
        "cannot write the robot's pose to {path}: {source}: check that the directory exists and is writable"
    )]
    Write {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        source: std::io::Error,
    },
    /// Reading failed (other than a missing file).
    #[error("cannot read the robot's pose from {path}: {source}")]
    Read {
        /// The file.
        path: PathBuf,
        /// What went wrong.
        source: std::io::Error,
    },
    /// The text is not a pose.
    #[error("{path} does not hold a pose (`x_m y_m heading_rad`): `{text}`")]
    Malformed {
        /// The file.
        path: PathBuf,
        /// What it holds.
        text: String,
    },
}

/// The pose file in a shared directory.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct PoseFile {
    path: PathBuf,
}

impl PoseFile {
    /// The pose file of the shared directory `dir`.
    pub fn in_dir(dir: &Path) -> Self {
        Self {
            path: dir.join(POSE_FILE_NAME),
        }
    }

    /// Its path.
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Replaces the pose, atomically.
    ///
    /// # Errors
    /// When the directory is missing or not writable.
    pub fn write(&self, pose: Pose2) -> Result<(), PoseFileError> {
        let error = |source| PoseFileError::Write {
            path: self.path.clone(),
            source,
        };
        let mut temporary = self.path.clone().into_os_string();
        temporary.push(format!(".{}.tmp", std::process::id()));
        let temporary = PathBuf::from(temporary);
        let mut file = std::fs::File::create(&temporary).map_err(error)?;
        // Rust prints the shortest text that reads back as the same f64.
        writeln!(file, "{} {} {}", pose.x_m, pose.y_m, pose.heading_rad).map_err(error)?;
        drop(file);
        std::fs::rename(&temporary, &self.path).map_err(error)
    }

    /// The pose, or `None` when no pose was written yet.
    ///
    /// # Errors
    /// When the file cannot be read or does not hold a pose.
    pub fn read(&self) -> Result<Option<Pose2>, PoseFileError> {
        let text = match std::fs::read_to_string(&self.path) {
            Ok(text) => text,
            Err(error) if error.kind() == std::io::ErrorKind::NotFound => return Ok(None),
            Err(source) => {
                return Err(PoseFileError::Read {
                    path: self.path.clone(),
                    source,
                });
            }
        };
        let numbers: Vec<f64> = text
            .split_whitespace()
            .map(str::parse)
            .collect::<Result<_, _>>()
            .unwrap_or_default();
        match numbers[..] {
            [x, y, heading] if numbers.iter().all(|n| n.is_finite()) => {
                Ok(Some(Pose2::new(x, y, heading)))
            }
            _ => Err(PoseFileError::Malformed {
                path: self.path.clone(),
                text: text.trim().chars().take(80).collect(),
            }),
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_pose_reads_back_exactly_and_a_missing_file_is_no_pose() {
        let dir = tempfile::tempdir().unwrap();
        let file = PoseFile::in_dir(dir.path());
        assert_eq!(file.read().unwrap(), None);
        let pose = Pose2::new(3.0, 12.5, -0.1 / 3.0);
        file.write(pose).unwrap();
        assert_eq!(file.read().unwrap(), Some(pose));
        let moved = Pose2::new(3.25, 12.5, 0.0);
        file.write(moved).unwrap();
        assert_eq!(file.read().unwrap(), Some(moved));
        let leftovers: Vec<_> = std::fs::read_dir(dir.path())
            .unwrap()
            .map(|entry| entry.unwrap().file_name())
            .collect();
        assert_eq!(leftovers, vec![POSE_FILE_NAME], "no temporary file is left");
    }

    #[test]
    fn errors_name_the_file() {
        let dir = tempfile::tempdir().unwrap();
        let file = PoseFile::in_dir(dir.path());
        std::fs::write(file.path(), "1 2\n").unwrap();
        let error = file.read().unwrap_err().to_string();
        assert!(
            error.contains(POSE_FILE_NAME) && error.contains("`1 2`"),
            "{error}"
        );
        let missing = PoseFile::in_dir(&dir.path().join("gone"));
        let error = missing.write(Pose2::default()).unwrap_err().to_string();
        assert!(
            error.contains("gone") && error.contains("writable"),
            "{error}"
        );
    }
}
