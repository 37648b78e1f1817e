//! How a recording is written: where, compressed how, chunked and rotated how.

use std::fmt;
use std::path::PathBuf;
use std::str::FromStr;

use thiserror::Error;

use crate::companion::CompanionOptions;

/// One second, in nanoseconds.
pub const SECOND_NS: i64 = 1_000_000_000;

/// How chunks are compressed.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum Compression {
    /// Zstandard (the default: the smallest files).
    #[default]
    Zstd,
    /// LZ4 (the fastest to write and read).
    Lz4,
    /// None.
    None,
}

impl Compression {
    /// The value the MCAP writer takes.
    pub(crate) fn to_mcap(self) -> Option<mcap::Compression> {
        match self {
            Self::Zstd => Some(mcap::Compression::Zstd),
            Self::Lz4 => Some(mcap::Compression::Lz4),
            Self::None => None,
        }
    }

    /// The name in chunk records and on the command line: `zstd`, `lz4` or `none`.
    #[must_use]
    pub fn name(self) -> &'static str {
        match self {
            Self::Zstd => "zstd",
            Self::Lz4 => "lz4",
            Self::None => "none",
        }
    }
}

impl fmt::Display for Compression {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.name())
    }
}

/// A compression name that is not `zstd`, `lz4` or `none`.
#[derive(Debug, Clone, PartialEq, Eq, Error)]
#[error("unknown compression `{0}`: use zstd, lz4 or none")]
pub struct UnknownCompression(pub String);

impl FromStr for Compression {
    type Err = UnknownCompression;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "zstd" => Ok(Self::Zstd),
            "lz4" => Ok(Self::Lz4),
            "none" | "" => Ok(Self::None),
            other => Err(UnknownCompression(other.to_owned())),
        }
    }
}

/// The robot description stored in every file of a recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RobotDescription {
    /// Its file name (`sim.toml`), the key of the metadata entry.
    pub file_name: String,
    /// Its TOML text, unchanged.
    pub toml: String,
}

/// How to write a recording. [`RecorderOptions::new`] gives the defaults.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecorderOptions {
    /// The output file. With rotation, the parts are `STEM_000.mcap`, `STEM_001.mcap`, ...
    /// beside it and the parts index is `STEM.parts.json` (see [`crate::index`]).
    pub path: PathBuf,
    /// Chunk compression.
    pub compression: Compression,
    /// A chunk is closed (written, indexed and flushed to the system) when its
    /// uncompressed size reaches this. A message of a quarter of it or more (a camera
    /// frame) is written in a chunk of its own, so that readers of other topics skip it.
    pub chunk_size_bytes: u64,
    /// A chunk is also closed, and the file synced, when this much receive time has
    /// passed since the last flush; crash safety is bounded by it.
    pub flush_period_ns: i64,
    /// The recorder's stats message (`/lewis/recorder/stats`) is written this often.
    pub stats_period_ns: i64,
    /// Start a new part when the current one holds this many bytes.
    pub split_size_bytes: Option<u64>,
    /// Start a new part when the current one spans this much receive time.
    pub split_duration_ns: Option<i64>,
    /// The robot description, stored as metadata `lewis.robot`.
    pub robot_description: Option<RobotDescription>,
    /// Disk space held beside the file and given back when the disk is full, so that the
    /// file can still be closed with its summary; 0 disables it. It must hold the last
    /// chunk's tail and indexes plus the summary: a few chunk sizes is plenty.
    pub disk_reserve_bytes: u64,
    /// Sync the file to the disk at every time-based flush (survives a power cut, not
    /// only a crash of the recorder). The sync runs on a thread of its own, so that the
    /// writer never waits for the disk; the file is synced completely when it is closed.
    pub sync_on_flush: bool,
    /// The provider name in the header of the recorder's own stats messages.
    pub recorder_name: String,
    /// What the stats messages name as the file, instead of the part's file name: a
    /// recording whose bytes must not depend on where it is written (a replay: two replays
    /// to different names are the same file) sets it. The parts index, outside the
    /// recording, keeps the real names, which locate the parts.
    pub file_label: Option<String>,
    /// Companion channels of ROS 2's standard types written beside the robot's own
    /// ([`crate::companion`]); `None` writes none.
    pub companions: Option<CompanionOptions>,
}

impl RecorderOptions {
    /// The defaults: zstd, 1 MiB chunks, flushed at least every second, stats every
    /// second, no rotation, a 4 MiB disk reserve, synced at each timed flush, no companion
    /// channels.
    #[must_use]
    pub fn new(path: impl Into<PathBuf>) -> Self {
        Self {
            path: path.into(),
            compression: Compression::Zstd,
            chunk_size_bytes: 1024 * 1024,
            flush_period_ns: SECOND_NS,
            stats_period_ns: SECOND_NS,
            split_size_bytes: None,
            split_duration_ns: None,
            robot_description: None,
            disk_reserve_bytes: 4 * 1024 * 1024,
            sync_on_flush: true,
            recorder_name: "recorder".to_owned(),
            file_label: None,
            companions: None,
        }
    }

    /// Whether the recording is split into parts.
    #[must_use]
    pub fn splits(&self) -> bool {
        self.split_size_bytes.is_some() || self.split_duration_ns.is_some()
    }
}
