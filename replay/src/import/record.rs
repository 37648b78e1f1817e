//! An import written as a Lewis recording (`lewis import carmen LOG -o OUT.mcap`, `lewis
//! import ros2 BAG.mcap`, the latter with the bag's own messages beside), through
//! the recorder, the one place that writes MCAP: the robot description of the import as
//! metadata `lewis.robot` (as `lewis up` stores it), the interface XML (the recorder adds it
//! to every file), one channel per imported topic with the usual metadata (provider,
//! interface, version, `kind`), and every message with its time as both log and publish
//! time. What the import made up is said on its channel (`derived`): the sonar derived from
//! the laser, the Distance computed at import, the heartbeats.
//!
//! Time never goes backwards in the file: the import's times are non-decreasing by
//! construction, and this writer checks it again (a message earlier than the one before it
//! is an error, never written).

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_recorder::live::META_KIND;
use lewis_recorder::{
    ChannelId, ChannelSpec, Compression, RecordError, Recorder, RecorderOptions, RecordingReport,
    RobotDescription, Sample,
};
use lewis_runtime::robot::{self, RobotError};

use super::carmen::robot::{robot_name, robot_toml};
use super::carmen::{CarmenImport, DISTANCE, ImportError, ImportedMessage, Payload, SONAR};
use super::ros2::{self, ImportError as Ros2ImportError, Out, Ros2Import};

/// The provider name of the import's own stats messages (the recorder's).
pub const IMPORTER_NAME: &str = "lewis-import";

/// How to write an import.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct WriteOptions {
    /// The output file (parts `STEM_000.mcap`, ... beside it when split).
    pub output: PathBuf,
    /// Chunk compression.
    pub compression: Compression,
    /// Start a new part at this size.
    pub split_size_bytes: Option<u64>,
    /// Start a new part after this much log time.
    pub split_duration_ns: Option<i64>,
}

impl WriteOptions {
    /// One zstd-compressed file at `output`.
    #[must_use]
    pub fn new(output: impl Into<PathBuf>) -> Self {
        Self {
            output: output.into(),
            compression: Compression::Zstd,
            split_size_bytes: None,
            split_duration_ns: None,
        }
    }
}

/// What was written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Written {
    /// The files and the counts per topic (from the recorder).
    pub recording: RecordingReport,
    /// The robot description stored in the recording.
    pub robot_toml: String,
    /// Messages written per topic (the recorder's stats excluded).
    pub messages: BTreeMap<String, u64>,
    /// The log time of the first and the last message, in ns.
    pub span_ns: Option<(i64, i64)>,
}

/// Why an import could not be written.
#[derive(Debug, thiserror::Error)]
pub enum WriteError {
    /// Reading the log failed in its second pass.
    #[error(transparent)]
    Import(#[from] ImportError),
    /// The recorder refused (the message names the file and what to do).
    #[error(transparent)]
    Record(#[from] RecordError),
    /// The robot description made for the import is not valid: a bug of the importer.
    #[error("the robot description made for {path} is not valid (please report it): {source}")]
    Robot {
        /// The log.
        path: PathBuf,
        /// What is wrong with it.
        source: RobotError,
    },
    /// A message would have been written earlier than the one before it.
    #[error(
        "{topic}: a message at {time_ns} ns after one at {before_ns} ns; time must not go backwards, nothing after it was written"
    )]
    TimeGoesBack {
        /// Its topic.
        topic: String,
        /// Its time.
        time_ns: i64,
        /// The time of the message before it.
        before_ns: i64,
    },
    /// An imported topic is of no interface this build knows (an importer bug).
    #[error("{topic}: interface {interface} is unknown to this build of lewis")]
    UnknownInterface {
        /// The topic.
        topic: String,
        /// The interface.
        interface: String,
    },
}

/// Writes `import` as a Lewis recording; `progress` is told the messages written so far,
/// every few thousand.
///
/// # Errors
/// When the log cannot be read again, the recorder refuses (an existing file, a missing
/// folder, a full disk), or time would go backwards.
pub fn write_carmen(
    import: &CarmenImport,
    options: &WriteOptions,
    progress: &mut dyn FnMut(u64),
) -> Result<Written, WriteError> {
    let report = import.report();
    let toml = robot_toml(report);
    let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    let file_name = format!("{}.toml", robot_name(&report.path));
    robot::parse(&toml, Path::new(&file_name), &known).map_err(|source| WriteError::Robot {
        path: report.path.clone(),
        source,
    })?;
    let mut recorder_options = RecorderOptions::new(&options.output);
    recorder_options.compression = options.compression;
    recorder_options.split_size_bytes = options.split_size_bytes;
    recorder_options.split_duration_ns = options.split_duration_ns;
    recorder_options.sync_on_flush = false;
    recorder_options.robot_description = Some(RobotDescription {
        file_name,
        toml: toml.clone(),
    });
    IMPORTER_NAME.clone_into(&mut recorder_options.recorder_name);
    let mut recorder = Recorder::create(recorder_options)?;
    let source = report
        .path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut channels: BTreeMap<String, ChannelId> = BTreeMap::new();
    let mut messages: BTreeMap<String, u64> = BTreeMap::new();
    let mut span_ns: Option<(i64, i64)> = None;
    let mut buffer = Vec::new();
    let mut written = 0u64;
    for message in import.messages()? {
        let message = message?;
        if let Some((_, last)) = span_ns
            && message.time_ns < last
        {
            return Err(WriteError::TimeGoesBack {
                topic: message.channel,
                time_ns: message.time_ns,
                before_ns: last,
            });
        }
        let channel = match channels.get(&message.channel) {
            Some(id) => *id,
            None => {
                let id = recorder.add_channel(channel_spec(&message, &source)?)?;
                channels.insert(message.channel.clone(), id);
                id
            }
        };
        message.payload.encode_to_vec(&mut buffer);
        let header = message.payload.header();
        recorder.write(&Sample {
            channel,
            seq: header.seq,
            publish_time_ns: header.publish_time_ns,
            log_time_ns: message.time_ns,
            data: &buffer,
        })?;
        *messages.entry(message.channel).or_default() += 1;
        span_ns = Some(
            span_ns.map_or((message.time_ns, message.time_ns), |(first, _)| {
                (first, message.time_ns)
            }),
        );
        written += 1;
        if written.is_multiple_of(4096) {
            progress(written);
        }
    }
    progress(written);
    let recording = recorder.close()?;
    Ok(Written {
        recording,
        robot_toml: toml,
        messages,
        span_ns,
    })
}

/// The MCAP channel of an imported topic.
fn channel_spec(message: &ImportedMessage, source: &str) -> Result<ChannelSpec, WriteError> {
    let interface = message.payload.interface();
    let info = lewis_interfaces::interface_info(interface).ok_or_else(|| {
        WriteError::UnknownInterface {
            topic: message.channel.clone(),
            interface: interface.to_owned(),
        }
    })?;
    let provider = &message.payload.header().provider;
    let mut spec = ChannelSpec::publication(info, provider, &message.channel);
    let (kind, derived) = match &message.payload {
        Payload::Health(_) => (
            "health",
            Some(
                "made by the import: the log says nothing of health, its sources are taken as alive from its first record to its last",
            ),
        ),
        Payload::RangeFinder(_) if provider == SONAR => (
            "data",
            Some("derived from the laser at a lower resolution, not a sensor of the logged robot"),
        ),
        Payload::Distance(_) if provider == DISTANCE => (
            "data",
            Some(
                "computed at import from /laser/RangeFinder by the range_distance service's code, as it would have published it live",
            ),
        ),
        Payload::Blobs(_) if provider == ros2::BLOBFINDER => (
            "data",
            Some(
                "computed at import from /camera/ImageSource by the blobfinder service's code, as it would have published it live",
            ),
        ),
        _ => ("data", None),
    };
    spec.extra_metadata
        .insert(META_KIND.to_owned(), kind.to_owned());
    spec.extra_metadata
        .insert("imported_from".to_owned(), source.to_owned());
    if let Some(derived) = derived {
        spec.extra_metadata
            .insert("derived".to_owned(), derived.to_owned());
    }
    Ok(spec)
}

/// Why a ROS 2 bag's import could not be written.
#[derive(Debug, thiserror::Error)]
pub enum Ros2WriteError {
    /// The bag cannot be imported (found in the last pass: the bag changed).
    #[error(transparent)]
    Import(#[from] Ros2ImportError),
    /// The recorder refused.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// The robot description made for the import is not valid: a bug of the importer.
    #[error("the robot description made for {path} is not valid (please report it): {source}")]
    Robot {
        /// The bag.
        path: PathBuf,
        /// What is wrong with it.
        source: RobotError,
    },
    /// The output exists.
    #[error("{} exists: give another -o, or remove it first", path.display())]
    Exists {
        /// The output.
        path: PathBuf,
    },
    /// The finished import could not be moved to its name.
    #[error("cannot rename {} to {}: {source}", from.display(), to.display())]
    Rename {
        /// The temporary file.
        from: PathBuf,
        /// The output.
        to: PathBuf,
        /// Why.
        source: std::io::Error,
    },
    /// An imported topic is of no interface this build knows (an importer bug).
    #[error(transparent)]
    Channel(#[from] WriteError),
}

/// The temporary file an import is written to, beside `output` (renamed at the end, so
/// that nothing is left half-written under the output's name).
#[must_use]
pub fn temporary_path(output: &Path) -> PathBuf {
    let name = output
        .file_name()
        .map_or_else(|| "import".to_owned(), |f| f.to_string_lossy().into_owned());
    output.with_file_name(format!(".{name}.importing.mcap"))
}

/// Writes a ROS 2 bag's import as one Lewis recording at `output` (through a temporary file
/// beside it, renamed once complete, removed on failure); `progress` is told the messages
/// written so far, every few thousand.
///
/// # Errors
/// The output exists, the bag cannot be read again, or the recorder refuses.
pub fn write_ros2(
    import: &Ros2Import,
    output: &Path,
    compression: Compression,
    progress: &mut dyn FnMut(u64),
) -> Result<Written, Ros2WriteError> {
    if output.exists() {
        return Err(Ros2WriteError::Exists {
            path: output.to_owned(),
        });
    }
    let temporary = temporary_path(output);
    // A temporary file left by an import that was killed is ours to replace.
    let _ = std::fs::remove_file(&temporary);
    let result = write_ros2_to(import, &temporary, compression, progress);
    let written = match result {
        Ok(written) => written,
        Err(e) => {
            let _ = std::fs::remove_file(&temporary);
            return Err(e);
        }
    };
    if let Err(source) = std::fs::rename(&temporary, output) {
        let _ = std::fs::remove_file(&temporary);
        return Err(Ros2WriteError::Rename {
            from: temporary,
            to: output.to_owned(),
            source,
        });
    }
    let mut written = written;
    written.recording.parts = vec![output.to_owned()];
    Ok(written)
}

fn write_ros2_to(
    import: &Ros2Import,
    path: &Path,
    compression: Compression,
    progress: &mut dyn FnMut(u64),
) -> Result<Written, Ros2WriteError> {
    let report = import.report();
    let toml = ros2::robot_toml(report);
    let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    let file_name = format!("{}.toml", ros2::robot_name(&report.path));
    robot::parse(&toml, Path::new(&file_name), &known).map_err(|source| Ros2WriteError::Robot {
        path: report.path.clone(),
        source,
    })?;
    let mut options = RecorderOptions::new(path);
    options.compression = compression;
    options.sync_on_flush = false;
    options.robot_description = Some(RobotDescription {
        file_name,
        toml: toml.clone(),
    });
    IMPORTER_NAME.clone_into(&mut options.recorder_name);
    let mut recorder = Recorder::create(options)?;
    let source = report
        .path
        .file_name()
        .map(|f| f.to_string_lossy().into_owned())
        .unwrap_or_default();
    let mut channels: BTreeMap<String, ChannelId> = BTreeMap::new();
    let mut messages: BTreeMap<String, u64> = BTreeMap::new();
    let mut span_ns: Option<(i64, i64)> = None;
    let mut buffer = Vec::new();
    let mut written = 0u64;
    import.stream::<Ros2WriteError, _>(|out| {
        let (topic, seq, publish_ns, log_ns, data): (&str, u64, i64, i64, &[u8]) = match &out {
            Out::Lewis(message) => {
                if !channels.contains_key(&message.channel) {
                    let id = recorder.add_channel(channel_spec(message, &source)?)?;
                    channels.insert(message.channel.clone(), id);
                }
                message.payload.encode_to_vec(&mut buffer);
                let header = message.payload.header();
                (
                    &message.channel,
                    header.seq,
                    header.publish_time_ns,
                    message.time_ns,
                    &buffer,
                )
            }
            Out::Original(m) => {
                if !channels.contains_key(&m.topic.name) {
                    let id = recorder.add_channel(original_spec(m.topic, &source))?;
                    channels.insert(m.topic.name.clone(), id);
                }
                let log = i64::try_from(m.log_time_ns).unwrap_or(i64::MAX);
                (
                    &m.topic.name,
                    m.index + 1,
                    i64::try_from(m.publish_time_ns).unwrap_or(log),
                    log,
                    m.data,
                )
            }
        };
        let Some(&channel) = channels.get(topic) else {
            return Ok(());
        };
        recorder.write(&Sample {
            channel,
            seq,
            publish_time_ns: publish_ns,
            log_time_ns: log_ns,
            data,
        })?;
        *messages.entry(topic.to_owned()).or_default() += 1;
        span_ns = Some(span_ns.map_or((log_ns, log_ns), |(first, last)| {
            (first.min(log_ns), last.max(log_ns))
        }));
        written += 1;
        if written.is_multiple_of(4096) {
            progress(written);
        }
        Ok(())
    })?;
    progress(written);
    let recording = recorder.close()?;
    Ok(Written {
        recording,
        robot_toml: toml,
        messages,
        span_ns,
    })
}

/// The channel of a bag's topic kept as it is: its schema and encoding, the bag's type as
/// the interface (no Lewis interface reads it), `kind = "original"`.
fn original_spec(topic: &ros2::bag::Topic, source: &str) -> ChannelSpec {
    let mut extra = BTreeMap::new();
    extra.insert(META_KIND.to_owned(), "original".to_owned());
    extra.insert("imported_from".to_owned(), source.to_owned());
    ChannelSpec {
        topic: topic.name.clone(),
        schema_name: topic.type_name.clone(),
        schema_text: topic.schema_text.clone(),
        provider: "ros2".to_owned(),
        interface: topic.type_name.clone(),
        interface_version: String::new(),
        extra_metadata: extra,
    }
}
