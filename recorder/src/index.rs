//! The parts index of a rotated recording: a small JSON file beside the parts that lists
//! them in order, so that replay takes the set as one run.
//!
//! `-o DIR/run.mcap` with rotation writes `DIR/run_000.mcap`, `DIR/run_001.mcap`, ... and
//! `DIR/run.parts.json`:
//!
//! ```json
//! {
//!   "format": "lewis-recording-parts",
//!   "version": 1,
//!   "parts": [
//!     { "file": "run_000.mcap", "complete": true, "message_count": 1200,
//!       "first_log_time_ns": 1000, "last_log_time_ns": 59999000 },
//!     { "file": "run_001.mcap", "complete": false, "message_count": 0,
//!       "first_log_time_ns": null, "last_log_time_ns": null }
//!   ]
//! }
//! ```
//!
//! File names are relative to the index's folder. The index is rewritten (to a temporary
//! file, then renamed) when a part opens and when it closes, so after a crash it lists
//! every part, the last one with `"complete": false` (repair it with `lewis recover`).

use std::fs;
use std::path::{Path, PathBuf};

use serde::{Deserialize, Serialize};
use thiserror::Error;

/// The `format` value of a parts index.
pub const FORMAT: &str = "lewis-recording-parts";
/// The `version` this crate writes and reads.
pub const VERSION: u32 = 1;

/// The parts of a rotated recording, in order.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PartsIndex {
    /// Always [`FORMAT`].
    pub format: String,
    /// Always [`VERSION`].
    pub version: u32,
    /// The parts, in recording order.
    pub parts: Vec<PartEntry>,
}

/// One part of a rotated recording.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct PartEntry {
    /// Its file name, relative to the index's folder.
    pub file: String,
    /// Whether it was closed with its summary.
    pub complete: bool,
    /// Messages written to it (known when complete).
    pub message_count: u64,
    /// Receive time of its first message.
    pub first_log_time_ns: Option<i64>,
    /// Receive time of its last message.
    pub last_log_time_ns: Option<i64>,
}

/// Why a parts index could not be read.
#[derive(Debug, Error)]
pub enum IndexError {
    /// The file could not be read.
    #[error("cannot read the parts index {}: {source}", path.display())]
    Read {
        /// The index.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// It is not a parts index this version understands.
    #[error("{} is not a parts index of a Lewis recording: {reason}", path.display())]
    Invalid {
        /// The index.
        path: PathBuf,
        /// What is wrong.
        reason: String,
    },
}

impl PartsIndex {
    /// An index with no parts yet.
    #[must_use]
    pub fn new() -> Self {
        Self {
            format: FORMAT.to_owned(),
            version: VERSION,
            parts: Vec::new(),
        }
    }

    /// Reads the index at `path`.
    ///
    /// # Errors
    /// When it cannot be read or is not a parts index.
    pub fn read(path: &Path) -> Result<Self, IndexError> {
        let text = fs::read_to_string(path).map_err(|source| IndexError::Read {
            path: path.to_path_buf(),
            source,
        })?;
        let invalid = |reason: String| IndexError::Invalid {
            path: path.to_path_buf(),
            reason,
        };
        let index: Self = serde_json::from_str(&text).map_err(|e| invalid(e.to_string()))?;
        if index.format != FORMAT || index.version != VERSION {
            return Err(invalid(format!(
                "format `{}` version {}, expected `{FORMAT}` version {VERSION}",
                index.format, index.version
            )));
        }
        if let Some(bad) = index
            .parts
            .iter()
            .find(|p| Path::new(&p.file).file_name() != Some(p.file.as_ref()))
        {
            return Err(invalid(format!(
                "part `{}` is not a file name beside the index",
                bad.file
            )));
        }
        Ok(index)
    }

    /// The paths of the parts, in order, for the index at `index_path`.
    #[must_use]
    pub fn part_paths(&self, index_path: &Path) -> Vec<PathBuf> {
        let folder = index_path.parent().unwrap_or_else(|| Path::new("."));
        self.parts.iter().map(|p| folder.join(&p.file)).collect()
    }

    /// Writes the index at `path`, atomically (temporary file, then rename).
    pub(crate) fn write(&self, path: &Path) -> std::io::Result<()> {
        let text = serde_json::to_string_pretty(self).map_err(std::io::Error::other)?;
        let temporary = path.with_extension("json.tmp");
        fs::write(&temporary, text + "\n")?;
        fs::rename(&temporary, path)
    }
}

impl Default for PartsIndex {
    fn default() -> Self {
        Self::new()
    }
}

/// The parts index of a rotated recording written to `path`: `STEM.parts.json`.
#[must_use]
pub fn index_path(path: &Path) -> PathBuf {
    path.with_file_name(format!("{}.parts.json", stem(path)))
}

/// The file of part `number` of a rotated recording written to `path`: `STEM_NNN.mcap`.
#[must_use]
pub fn part_path(path: &Path, number: u32) -> PathBuf {
    path.with_file_name(format!("{}_{number:03}.mcap", stem(path)))
}

fn stem(path: &Path) -> String {
    path.file_stem().map_or_else(
        || "recording".to_owned(),
        |s| s.to_string_lossy().into_owned(),
    )
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn parts_and_index_are_named_after_the_output_stem() {
        let path = Path::new("/logs/run.mcap");
        assert_eq!(part_path(path, 0), Path::new("/logs/run_000.mcap"));
        assert_eq!(part_path(path, 12), Path::new("/logs/run_012.mcap"));
        assert_eq!(index_path(path), Path::new("/logs/run.parts.json"));
    }

    #[test]
    fn an_index_reads_back_what_was_written() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.parts.json");
        let mut index = PartsIndex::new();
        index.parts.push(PartEntry {
            file: "run_000.mcap".into(),
            complete: true,
            message_count: 3,
            first_log_time_ns: Some(1),
            last_log_time_ns: Some(9),
        });
        index.write(&path).unwrap();
        let read = PartsIndex::read(&path).unwrap();
        assert_eq!(read, index);
        assert_eq!(read.part_paths(&path), [dir.path().join("run_000.mcap")]);
    }

    #[test]
    fn an_index_naming_a_file_elsewhere_is_refused() {
        let dir = tempfile::tempdir().unwrap();
        let path = dir.path().join("run.parts.json");
        let text = r#"{"format":"lewis-recording-parts","version":1,"parts":[
            {"file":"../etc/x.mcap","complete":true,"message_count":0,
             "first_log_time_ns":null,"last_log_time_ns":null}]}"#;
        fs::write(&path, text).unwrap();
        let error = PartsIndex::read(&path).unwrap_err();
        assert!(
            error
                .to_string()
                .contains("`../etc/x.mcap` is not a file name"),
            "{error}"
        );
    }
}
