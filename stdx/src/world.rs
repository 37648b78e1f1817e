//! Where a robot's world is drawn from: the header of a world folder's `world.toml` (the
//! map image, its scale and where it lies), and how the folder a robot file names is found.
//!
//! Displays need only this much of a world: the supervisor's page draws the robot on the
//! map, the viewer and the mission picture draw the path over it. The simulator reads the
//! whole file with its own validating loader (every field, with line and column), because
//! it needs the walls, signs and people too; this header agrees with it on the fields both
//! read.

use std::path::{Path, PathBuf};

/// The map of a world folder: an image whose bottom-left corner lies at `origin_m`.
#[derive(Debug, Clone, PartialEq)]
pub struct WorldHeader {
    /// The folder holding `world.toml`.
    pub folder: PathBuf,
    /// The map image (`map`, relative to the folder).
    pub image: PathBuf,
    /// Metres per pixel of the image.
    pub metres_per_pixel: f64,
    /// Where the image's bottom-left corner lies in the world frame, in metres.
    pub origin_m: [f64; 2],
}

/// Why a world's header could not be read.
#[derive(Debug, Clone, PartialEq, thiserror::Error)]
pub enum WorldHeaderError {
    /// No candidate folder has a `world.toml`.
    #[error("no world.toml in {}", tried.iter().map(|p| p.display().to_string()).collect::<Vec<_>>().join(", "))]
    NotFound {
        /// The folder as the robot file names it.
        world: String,
        /// The folders looked in, in order.
        tried: Vec<PathBuf>,
    },
    /// The file is there but its header is not usable.
    #[error("{}: {detail}", file.display())]
    Invalid {
        /// The `world.toml`.
        file: PathBuf,
        /// What is wrong.
        detail: String,
    },
}

/// Finds the world folder `world` and reads its header. The folder is looked for as
/// written (absolute, or relative to the current folder, as `lewis up` runs from the
/// repository's root), then relative to each folder above `near` (the robot file, or a
/// recording kept in the same repository).
///
/// # Errors
/// When no candidate folder has a `world.toml`, or its header is not usable.
pub fn find_world(world: &str, near: &Path) -> Result<WorldHeader, WorldHeaderError> {
    let tried = candidates(world, near);
    let Some(folder) = tried.iter().find(|f| f.join("world.toml").is_file()) else {
        return Err(WorldHeaderError::NotFound {
            world: world.to_owned(),
            tried,
        });
    };
    read_world_header(folder)
}

/// Reads the header of `folder/world.toml`: `map` (required), `metres_per_pixel`
/// (required, positive) and `origin_m` (`[x, y]`, default the origin).
///
/// # Errors
/// When the file cannot be read, is not TOML, or a field is missing or out of range.
pub fn read_world_header(folder: &Path) -> Result<WorldHeader, WorldHeaderError> {
    let file = folder.join("world.toml");
    let invalid = |detail: String| WorldHeaderError::Invalid {
        file: file.clone(),
        detail,
    };
    let text = std::fs::read_to_string(&file).map_err(|e| invalid(e.to_string()))?;
    let table: toml::Table = text
        .parse()
        .map_err(|e| invalid(format!("not TOML: {e}")))?;
    let map = table
        .get("map")
        .and_then(toml::Value::as_str)
        .ok_or_else(|| invalid("no `map` (the image's file name)".into()))?;
    let metres_per_pixel = table
        .get("metres_per_pixel")
        .and_then(number)
        .filter(|m| m.is_finite() && *m > 0.0)
        .ok_or_else(|| invalid("no positive `metres_per_pixel`".into()))?;
    let origin_m = match table.get("origin_m") {
        None => [0.0, 0.0],
        Some(value) => {
            let pair = value
                .as_array()
                .map(|a| a.iter().map(number).collect::<Vec<_>>());
            match pair.as_deref() {
                Some(&[Some(x), Some(y)]) if x.is_finite() && y.is_finite() => [x, y],
                _ => return Err(invalid("`origin_m` is not [x, y] in metres".into())),
            }
        }
    };
    Ok(WorldHeader {
        folder: folder.to_owned(),
        image: folder.join(map),
        metres_per_pixel,
        origin_m,
    })
}

/// Where `world` may be: as written, then relative to each folder above `near`.
fn candidates(world: &str, near: &Path) -> Vec<PathBuf> {
    let written = Path::new(world);
    let mut found = vec![written.to_owned()];
    if written.is_relative() {
        let near = std::path::absolute(near).unwrap_or_else(|_| near.to_owned());
        for folder in near.ancestors().skip(1) {
            let candidate = folder.join(written);
            if !found.contains(&candidate) {
                found.push(candidate);
            }
        }
    }
    found
}

/// A TOML number as `f64`: a float, or an integer written without a decimal point.
fn number(value: &toml::Value) -> Option<f64> {
    value
        .as_float()
        .or_else(|| value.as_integer().map(|i| i as f64))
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    fn folder_with(text: &str) -> tempfile::TempDir {
        let dir = tempfile::tempdir().unwrap();
        std::fs::write(dir.path().join("world.toml"), text).unwrap();
        dir
    }

    #[test]
    fn reads_the_header_and_defaults_the_origin() {
        let dir = folder_with("map = \"map.png\"\nmetres_per_pixel = 1\n[[signs]]\nat = 3\n");
        let header = read_world_header(dir.path()).unwrap();
        assert_eq!(header.image, dir.path().join("map.png"));
        assert!((header.metres_per_pixel - 1.0).abs() < f64::EPSILON);
        assert_eq!(header.origin_m, [0.0, 0.0]);
    }

    #[test]
    fn names_the_file_and_the_field_that_is_wrong() {
        for (text, expected) in [
            ("metres_per_pixel = 0.05", "no `map`"),
            (
                "map = \"m.png\"\nmetres_per_pixel = -1.0",
                "metres_per_pixel",
            ),
            (
                "map = \"m.png\"\nmetres_per_pixel = 0.05\norigin_m = [1.0]",
                "origin_m",
            ),
            ("map = ", "not TOML"),
        ] {
            let dir = folder_with(text);
            let error = read_world_header(dir.path()).unwrap_err().to_string();
            assert!(error.contains("world.toml"), "{error}");
            assert!(error.contains(expected), "{text}: {error}");
        }
    }

    #[test]
    fn finds_the_folder_above_the_file_that_names_it() {
        let root = tempfile::tempdir().unwrap();
        let world = root.path().join("worlds/hall");
        std::fs::create_dir_all(&world).unwrap();
        std::fs::write(
            world.join("world.toml"),
            "map = \"m.png\"\nmetres_per_pixel = 0.05\norigin_m = [1, 2.5]\n",
        )
        .unwrap();
        let robot = root.path().join("robots/deep/robot.toml");
        let header = find_world("worlds/hall", &robot).unwrap();
        assert_eq!(header.folder, world);
        assert_eq!(header.origin_m, [1.0, 2.5]);
        let missing = find_world("worlds/none", &robot).unwrap_err().to_string();
        assert!(
            missing.starts_with("no world.toml in worlds/none, "),
            "{missing}"
        );
    }
}
