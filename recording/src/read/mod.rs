//! A recording as Lewis reads it: one or more MCAP files (the parts of one run, or runs
//! to replay together), their channels, the robot description stored in them, and their
//! messages merged in one total order: log time, then topic, then the header's sequence
//! number (then file and position, so that even identical keys have a fixed order).
//!
//! The files may be given one by one, in any order, or as the parts index of a rotated
//! recording (`STEM.parts.json`, written by the recorder), which stands for its parts
//! ([`expand_inputs`]). [`RecordingFiles`] is the recording without the robot (what
//! `lewis play` needs: it plays foreign ROS 2 bags too); [`Recording`] requires the robot.
//!
//! Messages are streamed chunk by chunk through each file's indexes
//! ([`lewis_mcap::TimeOrdered`]), so memory does not grow with the recording: only the
//! messages that share one log time are held at once. A file without a summary (a recorder
//! that was killed) is refused with the command that repairs it.

mod read_ahead;
mod stream;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use lewis_mcap::format::{FORMAT_VERSION, RECORDING_METADATA, WrittenBy};
use lewis_mcap::{McapFile, OpenError, ReadError, Summary};
use lewis_recorder::ChannelSpec;
use lewis_recorder::index::{IndexError, PartsIndex};
use lewis_robot::{Robot, RobotError};

pub use read_ahead::ReadAhead;
pub use stream::{Messages, RecordedMessage};

/// The metadata record holding the robot description (written by the recorder).
pub use lewis_mcap::format::ROBOT_METADATA;

/// Why a recording cannot be replayed.
#[derive(Debug, thiserror::Error)]
pub enum RecordingError {
    /// No file was given.
    #[error("no recording given: name at least one MCAP file")]
    NoFiles,
    /// A file cannot be opened or read.
    // Not a `source`: the message says it, and a chain would say it twice.
    #[error("cannot read {path}: {error}")]
    Io {
        /// The file.
        path: PathBuf,
        /// What the system said.
        error: std::io::Error,
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
        "{paths}: no robot description (metadata `lewis.robot`){origin}, so there is nothing to re-simulate: only recordings made by `lewis up`, `lewis record --robot` or `lewis import` say which services ran. Publish it into live IPC with `lewis play {first}`, or see what it holds with `lewis info {first}`"
    )]
    NoRobot {
        /// The files, comma-separated.
        paths: String,
        /// Who wrote the first file, as its header says (`; written by rosbag2 (profile
        /// ros2)`), or nothing.
        origin: String,
        /// The first file.
        first: String,
    },
    /// A parts index cannot be used.
    #[error(transparent)]
    Index(#[from] IndexError),
    /// A parts index lists no part.
    #[error("the parts index {path} lists no part: the recording it indexes never started")]
    EmptyIndex {
        /// The index.
        path: PathBuf,
    },
    /// The same file is given twice (directly or through a parts index).
    #[error(
        "{path} is given twice (by name or through a parts index): give each part of a run once"
    )]
    Duplicate {
        /// The file.
        path: PathBuf,
    },
    /// The stored robot description is not valid.
    #[error("the robot description stored in {path}: {source}")]
    Robot {
        /// The file it came from.
        path: PathBuf,
        /// What is wrong with it.
        source: RobotError,
    },
    /// A file was written in a recording format newer than this build knows (see
    /// `lewis_mcap::format::FORMAT_VERSION`): it may hold what this build would misread.
    #[error(
        "{path} was written by lewis {lewis_version} in recording format {version}, and this build reads formats up to {supported}: replay it with lewis {lewis_version} or later"
    )]
    NewerFormat {
        /// The file.
        path: PathBuf,
        /// Its format version.
        version: u32,
        /// The version of Lewis that wrote it.
        lewis_version: String,
        /// The newest format this build reads.
        supported: u32,
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
    /// The channel's whole metadata (of its first file), for copying it unchanged.
    pub metadata: BTreeMap<String, String>,
}

impl Topic {
    /// The channel to write its messages on again, as it was: schema, provider,
    /// interface and metadata.
    #[must_use]
    pub fn channel_spec(&self) -> ChannelSpec {
        ChannelSpec {
            topic: self.name.to_string(),
            schema_name: self.schema_name.clone(),
            schema_text: self.schema_text.clone(),
            provider: self.provider.clone().unwrap_or_default(),
            interface: self.interface.clone().unwrap_or_default(),
            interface_version: self.interface_version.clone().unwrap_or_default(),
            extra_metadata: self.metadata.clone(),
        }
    }
}

/// The files of a parts index stand for it; other paths are kept. Every file once.
///
/// A path is a parts index when it ends in `.json` (`STEM.parts.json`, see
/// [`lewis_recorder::index`]); its parts are listed in recording order.
///
/// # Errors
/// When an index cannot be read, lists no part, or a file is given twice.
pub fn expand_inputs(paths: &[PathBuf]) -> Result<Vec<PathBuf>, RecordingError> {
    let mut out: Vec<PathBuf> = Vec::new();
    let mut seen = std::collections::BTreeSet::new();
    for path in paths {
        let parts = if path.extension().is_some_and(|e| e == "json") {
            let index = PartsIndex::read(path)?;
            if index.parts.is_empty() {
                return Err(RecordingError::EmptyIndex { path: path.clone() });
            }
            index.part_paths(path)
        } else {
            vec![path.clone()]
        };
        for part in parts {
            let key = part.canonicalize().unwrap_or_else(|_| part.clone());
            if !seen.insert(key) {
                return Err(RecordingError::Duplicate { path: part });
            }
            out.push(part);
        }
    }
    Ok(out)
}

/// The files of a recording, read through their summaries: topics, time span, and the
/// robot description if one is stored. No robot is required (see [`Recording`]).
#[derive(Debug)]
pub struct RecordingFiles {
    files: Vec<(McapFile, Summary)>,
    topics: BTreeMap<Arc<str>, Topic>,
    robot_text: Option<(PathBuf, String, String)>,
    start_ns: i64,
    end_ns: i64,
    message_count: u64,
}

impl RecordingFiles {
    /// Opens the files (parts indexes expanded, see [`expand_inputs`]): reads each summary
    /// and the first robot description found.
    ///
    /// # Errors
    /// When a file cannot be read, has no summary, or carries non-CDR channels.
    pub fn open(paths: &[PathBuf]) -> Result<Self, RecordingError> {
        let paths = expand_inputs(paths)?;
        if paths.is_empty() {
            return Err(RecordingError::NoFiles);
        }
        let mut files = Vec::new();
        let mut topics = BTreeMap::new();
        let mut robot_text: Option<(PathBuf, String, String)> = None;
        let (mut start_ns, mut end_ns, mut message_count) = (i64::MAX, i64::MIN, 0u64);
        for path in &paths {
            let mut file = McapFile::open(path).map_err(|error| open_error(path, error))?;
            let summary = match file.summary() {
                Ok(Some(summary)) => summary,
                Ok(None) => return Err(RecordingError::NoSummary { path: path.clone() }),
                Err(error) => return Err(read_error(path, error)),
            };
            check_format(&mut file, &summary)?;
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
                    metadata: channel.metadata.clone(),
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
                    let metadata = file
                        .metadata_at(index)
                        .map_err(|error| read_error(path, error))?;
                    if let Some((name, text)) = metadata.metadata.into_iter().next() {
                        robot_text = Some((path.clone(), name, text));
                        break;
                    }
                }
            }
            files.push((file, summary));
        }
        if start_ns > end_ns {
            (start_ns, end_ns) = (0, 0);
        }
        Ok(Self {
            files,
            topics,
            robot_text,
            start_ns,
            end_ns,
            message_count,
        })
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

    /// The files, in the order given (parts indexes expanded).
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.files.iter().map(|(file, _)| file.path())
    }

    /// The robot description's file name and TOML text, as stored, if any.
    #[must_use]
    pub fn robot_toml(&self) -> Option<(&str, &str)> {
        self.robot_text
            .as_ref()
            .map(|(_, name, text)| (name.as_str(), text.as_str()))
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

    /// The error for files that hold no robot description: who wrote them and what to do.
    fn no_robot(&self) -> RecordingError {
        let paths: Vec<String> = self.paths().map(|p| p.display().to_string()).collect();
        let first = paths.first().cloned().unwrap_or_default();
        let origin = self
            .files
            .first()
            .map(|(file, _)| file.header())
            .map(|h| {
                let library = if h.library.is_empty() {
                    "an unnamed library"
                } else {
                    h.library.as_str()
                };
                format!("; written by {library} (profile `{}`)", h.profile)
            })
            .unwrap_or_default();
        RecordingError::NoRobot {
            paths: paths.join(", "),
            origin,
            first,
        }
    }
}

/// An opened recording that says which services ran: its files, topics, robot and time
/// span.
#[derive(Debug)]
pub struct Recording {
    files: RecordingFiles,
    robot: Robot,
    robot_file_name: String,
    robot_toml: String,
}

impl Recording {
    /// Opens the files of a recording (parts indexes expanded, see [`expand_inputs`]): reads
    /// each summary and the robot description.
    ///
    /// # Errors
    /// When a file cannot be read, has no summary, carries non-CDR channels, or no file
    /// holds a valid robot description.
    pub fn open(paths: &[PathBuf]) -> Result<Self, RecordingError> {
        let files = RecordingFiles::open(paths)?;
        let Some((robot_path, robot_file_name, robot_toml)) = files.robot_text.clone() else {
            return Err(files.no_robot());
        };
        let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
            .iter()
            .map(|i| i.name)
            .collect();
        let origin = robot_path.join(ROBOT_METADATA);
        let robot = lewis_robot::parse(&robot_toml, &origin, &known).map_err(|source| {
            RecordingError::Robot {
                path: robot_path.clone(),
                source,
            }
        })?;
        Ok(Self {
            files,
            robot,
            robot_file_name,
            robot_toml,
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
        self.files.topics()
    }

    /// The log time of the first message, in nanoseconds.
    #[must_use]
    pub fn start_ns(&self) -> i64 {
        self.files.start_ns()
    }

    /// The log time of the last message, in nanoseconds.
    #[must_use]
    pub fn end_ns(&self) -> i64 {
        self.files.end_ns()
    }

    /// Messages in the recording (from the summaries' statistics).
    #[must_use]
    pub fn message_count(&self) -> u64 {
        self.files.message_count()
    }

    /// The files, in the order given (parts indexes expanded).
    pub fn paths(&self) -> impl Iterator<Item = &Path> {
        self.files.paths()
    }

    /// Every message, in the total order (see the module documentation).
    ///
    /// # Errors
    /// When a file cannot be opened again.
    pub fn messages(&self) -> Result<Messages, RecordingError> {
        self.files.messages()
    }

    /// The messages of some topics only, in the same order.
    ///
    /// # Errors
    /// When a file cannot be opened again.
    pub fn messages_on(&self, topics: &[&str]) -> Result<Messages, RecordingError> {
        self.files.messages_on(topics)
    }
}

fn as_ns(t: u64) -> i64 {
    i64::try_from(t).unwrap_or(i64::MAX)
}

/// Refuses a file written in a newer recording format than this build's. A file without
/// `lewis.recording` (a foreign bag) or without a version (made before versioning) is read
/// as it always was.
fn check_format(file: &mut McapFile, summary: &Summary) -> Result<(), RecordingError> {
    let path = file.path().to_path_buf();
    let records = file
        .metadata_named(summary, RECORDING_METADATA)
        .map_err(|error| read_error(&path, error))?;
    let Some(record) = records.first() else {
        return Ok(());
    };
    let written =
        WrittenBy::from_entries(&record.metadata).map_err(|reason| RecordingError::Format {
            path: path.clone(),
            reason,
        })?;
    match written {
        WrittenBy::Versioned {
            format_version,
            lewis_version,
            ..
        } if format_version > FORMAT_VERSION => Err(RecordingError::NewerFormat {
            path,
            version: format_version,
            lewis_version,
            supported: FORMAT_VERSION,
        }),
        _ => Ok(()),
    }
}

fn read_error(path: &Path, error: ReadError) -> RecordingError {
    match error {
        ReadError::Io(error) => RecordingError::Io {
            path: path.to_path_buf(),
            error,
        },
        ReadError::Format(e) => RecordingError::Format {
            path: path.to_path_buf(),
            reason: e.to_string(),
        },
    }
}

fn open_error(path: &Path, error: OpenError) -> RecordingError {
    match error {
        OpenError::Io(error) => RecordingError::Io {
            path: path.to_path_buf(),
            error,
        },
        OpenError::NotMcap { error, .. } => RecordingError::Format {
            path: path.to_path_buf(),
            reason: error.to_string(),
        },
    }
}
