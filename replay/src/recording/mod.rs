//! A recording as replay reads it: one or more MCAP files (the parts of one run, or runs
//! to replay together), their channels, the robot description stored in them, and their
//! messages merged in one total order: log time, then topic, then the header's sequence
//! number (then file and position, so that even identical keys have a fixed order).
//!
//! Messages are streamed chunk by chunk through each file's indexes
//! ([`mcap::sans_io::IndexedReader`]), so memory does not grow with the recording: only the
//! messages that share one log time are held at once. A file without a summary (a recorder
//! that was killed) is refused with the command that repairs it.

mod stream;

use std::collections::BTreeMap;
use std::fs::File;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use lewis_runtime::robot::{self, Robot, RobotError};
use mcap::Summary;

use crate::info::summary::{SummaryFailure, read_metadata, read_summary};

pub use stream::{Messages, RecordedMessage};

/// The metadata record holding the robot description (written by the recorder).
pub const ROBOT_METADATA: &str = "lewis.robot";

/// Why a recording cannot be replayed.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// No file was given.
    #[error("no recording given: name at least one MCAP file")]
    NoFiles,
    /// A file cannot be opened or read.
    #[error("cannot read {path}: {source}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
    /// A file is not a readable MCAP file.
    #[error("{path} is not a readable MCAP file: {reason}")]
    Format {
        /// The file.
        path: PathBuf,
        /// What the reader met.
        reason: String,
    },
    /// A file has no summary section, so it cannot be read by its indexes.
    #[error(
        "{path} has no summary section (its recorder did not close it): repair it with `lewis recover {path}` and replay the repaired file"
    )]
    NoSummary {
        /// The file.
        path: PathBuf,
    },
    /// No file holds a robot description.
    #[error(
        "no robot description (metadata `lewis.robot`) in {paths}: only recordings made by `lewis up` or `lewis import` say which services ran, so there is nothing to re-simulate (`lewis info` reads any MCAP file)"
    )]
    NoRobot {
        /// The files, comma-separated.
        paths: String,
    },
    /// The stored robot description is not valid.
    #[error("the robot description stored in {path}: {source}")]
    Robot {
        /// The file it came from.
        path: PathBuf,
        /// What is wrong with it.
        source: RobotError,
    },
    /// A channel's message encoding is not CDR.
    #[error(
        "{path}: topic {topic} is encoded as `{encoding}`; replay feeds only CDR messages of Lewis interfaces"
    )]
    NotCdr {
        /// The file.
        path: PathBuf,
        /// The topic.
        topic: String,
        /// Its encoding.
        encoding: String,
    },
}

/// One topic of the recording, as its channel record describes it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Topic {
    /// The topic name.
    pub name: Arc<str>,
    /// The schema name (`lewis_interfaces/msg/RangeFinder`).
    pub schema_name: String,
    /// The schema text (ros2msg).
    pub schema_text: String,
    /// The channel metadata `provider`, when given.
    pub provider: Option<String>,
    /// The channel metadata `interface`, when given.
    pub interface: Option<String>,
    /// The channel metadata `interface_version`, when given.
    pub interface_version: Option<String>,
    /// Messages on the topic, over all files (from the summaries' statistics).
    pub message_count: u64,
}

/// An opened recording: its files, topics, robot and time span.
#[derive(Debug)]
pub struct Recording {
    files: Vec<(PathBuf, Summary)>,
    topics: BTreeMap<Arc<str>, Topic>,
    robot: Robot,
    robot_file_name: String,
    robot_toml: String,
    start_ns: i64,
    end_ns: i64,
    message_count: u64,
}

impl Recording {
    /// Opens the files of a recording: reads each summary and the robot description.
    ///
    /// # Errors
    /// When a file cannot be read, has no summary, carries non-CDR channels, or no file
    /// holds a valid robot description.
    pub fn open(paths: &[PathBuf]) -> Result<Self, RecordingError> {
        if paths.is_empty() {
            return Err(RecordingError::NoFiles);
        }
        let mut files = Vec::new();
        let mut topics = BTreeMap::new();
        let mut robot_text: Option<(PathBuf, String, String)> = None;
        let (mut start_ns, mut end_ns, mut message_count) = (i64::MAX, i64::MIN, 0u64);
        for path in paths {
            let io = |source| RecordingError::Io {
                path: path.clone(),
                source,
            };
            let mut file = File::open(path).map_err(io)?;
            let size = file.metadata().map_err(io)?.len();
            let summary = match read_summary(&mut file, size) {
                Ok(Some(summary)) => summary,
                Ok(None) => return Err(RecordingError::NoSummary { path: path.clone() }),
                Err(failure) => return Err(failure_error(path, failure)),
            };
            for channel in summary.channels.values() {
                if channel.message_encoding != "cdr" {
                    return Err(RecordingError::NotCdr {
                        path: path.clone(),
                        topic: channel.topic.clone(),
                        encoding: channel.message_encoding.clone(),
                    });
                }
                let name: Arc<str> = Arc::from(channel.topic.as_str());
                let count = summary
                    .stats
                    .as_ref()
                    .and_then(|s| s.channel_message_counts.get(&channel.id).copied())
                    .unwrap_or(0);
                let topic = topics.entry(name.clone()).or_insert_with(|| Topic {
                    name,
                    schema_name: channel
                        .schema
                        .as_ref()
                        .map(|s| s.name.clone())
                        .unwrap_or_default(),
                    schema_text: channel
                        .schema
                        .as_ref()
                        .map(|s| String::from_utf8_lossy(&s.data).into_owned())
                        .unwrap_or_default(),
                    provider: channel.metadata.get("provider").cloned(),
                    interface: channel.metadata.get("interface").cloned(),
                    interface_version: channel.metadata.get("interface_version").cloned(),
                    message_count: 0,
                });
                topic.message_count += count;
            }
            if let Some(stats) = &summary.stats
                && stats.message_count > 0
            {
                start_ns = start_ns.min(as_ns(stats.message_start_time));
                end_ns = end_ns.max(as_ns(stats.message_end_time));
                message_count += stats.message_count;
            }
            if robot_text.is_none() {
                for index in summary
                    .metadata_indexes
                    .iter()
                    .filter(|i| i.name == ROBOT_METADATA)
                {
                    let metadata =
                        read_metadata(&mut file, index).map_err(|f| failure_error(path, f))?;
                    if let Some((name, text)) = metadata.metadata.into_iter().next() {
                        robot_text = Some((path.clone(), name, text));
                        break;
                    }
                }
            }
            files.push((path.clone(), summary));
        }
        let Some((robot_path, robot_file_name, robot_toml)) = robot_text else {
            return Err(RecordingError::NoRobot {
                paths: paths
                    .iter()
                    .map(|p| p.display().to_string())
                    .collect::<Vec<_>>()
                    .join(", "),
            });
        };
        let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
            .iter()
            .map(|i| i.name)
            .collect();
        let origin = robot_path.join(ROBOT_METADATA);
        let robot =
            robot::parse(&robot_toml, &origin, &known).map_err(|source| RecordingError::Robot {
                path: robot_path.clone(),
                source,
            })?;
        if start_ns > end_ns {
            (start_ns, end_ns) = (0, 0);
        }
        Ok(Self {
            files,
            topics,
            robot,
            robot_file_name,
            robot_toml,
            start_ns,
            end_ns,
            message_count,
        })
    }

    /// The robot description stored in the recording.
    #[must_use]
    pub fn robot(&self) -> &Robot {
        &self.robot
    }

    /// The robot description's file name and TOML text, as stored.
    #[must_use]
    pub fn robot_toml(&self) -> (&str, &str) {
        (&self.robot_file_name, &self.robot_toml)
    }

    /// Every topic, by name.
    #[must_use]
    pub fn topics(&self) -> &BTreeMap<Arc<str>, Topic> {
        &self.topics
    }

    /// The log time of the first message, in nanoseconds.
    #[must_use]
    pub fn start_ns(&self) -> i64 {
        self.start_ns
    }

    /// The log time of the last message, in nanoseconds.
    #[must_use]
    pub fn end_ns(&self) -> i64 {
        self.end_ns
    }

    /// Messages in the recording (from the summaries' statistics).
    #[must_use]
    pub fn message_count(&self) -> u64 {
        self.message_count
    }

    /// The files, in the order given.
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|(p, _)| p.as_path())
    }

    /// Every message, in the total order (see the module documentation).
    ///
    /// # Errors
    /// When a file cannot be opened again.
    pub fn messages(&self) -> Result<Messages, RecordingError> {
        Messages::open(&self.files, None)
    }

    /// The messages of some topics only, in the same order.
    ///
    /// # Errors
    /// When a file cannot be opened again.
    pub fn messages_on(&self, topics: &[&str]) -> Result<Messages, RecordingError> {
        Messages::open(&self.files, Some(topics))
    }
}

fn as_ns(t: u64) -> i64 {
    i64::try_from(t).unwrap_or(i64::MAX)
}

fn failure_error(path: &Path, failure: SummaryFailure) -> RecordingError {
    match failure {
        SummaryFailure::Io(source) => RecordingError::Io {
            path: path.to_path_buf(),
            source,
        },
        SummaryFailure::Format(e) => RecordingError::Format {
            path: path.to_path_buf(),
            reason: e.to_string(),
        },
    }
}
