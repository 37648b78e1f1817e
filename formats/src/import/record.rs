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
use lewis_robot::RobotError;
use lewis_ros2_map::qos::OFFERED_QOS_PROFILES;

use crate::whole_file::{RenameError, write_whole};

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
    let mut recorder_options = RecorderOptions::new(&options.output);
    recorder_options.compression = options.compression;
    recorder_options.split_size_bytes = options.split_size_bytes;
    recorder_options.split_duration_ns = options.split_duration_ns;
    let file_name = format!("{}.toml", robot_name(&report.path));
    let mut file = ImportFile::create(
        recorder_options,
        &report.path,
        robot_toml(report),
        file_name,
    )?;
    let mut buffer = Vec::new();
    let mut last_ns = None;
    for message in import.messages()? {
        let message = message?;
        if let Some(last) = last_ns
            && message.time_ns < last
        {
            return Err(WriteError::TimeGoesBack {
                topic: message.channel,
                time_ns: message.time_ns,
                before_ns: last,
            });
        }
        last_ns = Some(message.time_ns);
        file.write_lewis(&message, &mut buffer, progress)?;
    }
    file.finish(progress)
}

/// A recording being written by an importer: its robot description checked and stored as
/// `lewis up` stores it, one channel per topic, and the counts and time span kept for the
/// import's report.
struct ImportFile {
    recorder: Recorder,
    toml: String,
    /// The imported file's name, recorded on every channel as `imported_from`.
    source: String,
    channels: BTreeMap<String, ChannelId>,
    messages: BTreeMap<String, u64>,
    span_ns: Option<(i64, i64)>,
    written: u64,
}

impl ImportFile {
    /// Checks `toml` (made by the importer for `log`) and opens the recorder with it.
    fn create(
        mut options: RecorderOptions,
        log: &Path,
        toml: String,
        file_name: String,
    ) -> Result<Self, WriteError> {
        let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
            .iter()
            .map(|i| i.name)
            .collect();
        lewis_robot::parse(&toml, Path::new(&file_name), &known).map_err(|source| {
            WriteError::Robot {
                path: log.to_owned(),
                source,
            }
        })?;
        options.sync_on_flush = false;
        options.robot_description = Some(RobotDescription {
            file_name,
            toml: toml.clone(),
        });
        IMPORTER_NAME.clone_into(&mut options.recorder_name);
        let source = log
            .file_name()
            .map(|f| f.to_string_lossy().into_owned())
            .unwrap_or_default();
        Ok(Self {
            recorder: Recorder::create(options)?,
            toml,
            source,
            channels: BTreeMap::new(),
            messages: BTreeMap::new(),
            span_ns: None,
            written: 0,
        })
    }

    /// The channel of `topic`, added from `spec` (given the imported file's name) the first
    /// time it is seen.
    fn channel(
        &mut self,
        topic: &str,
        spec: impl FnOnce(&str) -> Result<ChannelSpec, WriteError>,
    ) -> Result<ChannelId, WriteError> {
        if let Some(id) = self.channels.get(topic) {
            return Ok(*id);
        }
        let id = self.recorder.add_channel(spec(&self.source)?)?;
        self.channels.insert(topic.to_owned(), id);
        Ok(id)
    }

    /// Writes one Lewis message the import made, on its topic's channel (added on first
    /// sight), encoded into `buffer`.
    fn write_lewis(
        &mut self,
        message: &ImportedMessage,
        buffer: &mut Vec<u8>,
        progress: &mut dyn FnMut(u64),
    ) -> Result<(), WriteError> {
        let channel = self.channel(&message.channel, |source| channel_spec(message, source))?;
        message.payload.encode_to_vec(buffer);
        let header = message.payload.header();
        self.write(
            channel,
            &message.channel,
            header.seq,
            header.publish_time_ns,
            message.time_ns,
            buffer,
            progress,
        )
    }

    /// Writes one message and counts it; `progress` hears of every 4096th.
    #[expect(
        clippy::too_many_arguments,
        reason = "a sample's fields, named at the call"
    )]
    fn write(
        &mut self,
        channel: ChannelId,
        topic: &str,
        seq: u64,
        publish_time_ns: i64,
        log_time_ns: i64,
        data: &[u8],
        progress: &mut dyn FnMut(u64),
    ) -> Result<(), WriteError> {
        self.recorder.write(&Sample {
            channel,
            seq,
            publish_time_ns,
            log_time_ns,
            data,
        })?;
        *self.messages.entry(topic.to_owned()).or_default() += 1;
        self.span_ns = Some(
            self.span_ns
                .map_or((log_time_ns, log_time_ns), |(first, last)| {
                    (first.min(log_time_ns), last.max(log_time_ns))
                }),
        );
        self.written += 1;
        if self.written.is_multiple_of(4096) {
            progress(self.written);
        }
        Ok(())
    }

    /// Closes the recording.
    fn finish(self, progress: &mut dyn FnMut(u64)) -> Result<Written, WriteError> {
        progress(self.written);
        Ok(Written {
            recording: self.recorder.close()?,
            robot_toml: self.toml,
            messages: self.messages,
            span_ns: self.span_ns,
        })
    }
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
    /// The output exists.
    #[error("{} exists: give another -o, or remove it first", path.display())]
    Exists {
        /// The output.
        path: PathBuf,
    },
    /// The finished import could not be moved to its name.
    #[error(transparent)]
    Rename(#[from] RenameError),
    /// Writing failed: the recorder refused, or the robot description or a channel made
    /// for the import is not valid (an importer bug).
    #[error(transparent)]
    Write(#[from] WriteError),
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
    let mut written = write_whole(output, |path| {
        write_ros2_to(import, path, compression, progress)
    })?;
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
    let mut options = RecorderOptions::new(path);
    options.compression = compression;
    let file_name = format!("{}.toml", ros2::robot_name(&report.path));
    let mut file = ImportFile::create(options, &report.path, ros2::robot_toml(report), file_name)?;
    let mut buffer = Vec::new();
    import.stream::<Ros2WriteError, _>(|out| {
        match &out {
            Out::Lewis(message) => {
                file.write_lewis(message, &mut buffer, progress)?;
            }
            Out::Original(m) => {
                let channel =
                    file.channel(&m.topic.name, |source| Ok(original_spec(m.topic, source)))?;
                let log = i64::try_from(m.log_time_ns).unwrap_or(i64::MAX);
                file.write(
                    channel,
                    &m.topic.name,
                    m.index + 1,
                    i64::try_from(m.publish_time_ns).unwrap_or(log),
                    log,
                    m.data,
                    progress,
                )?;
            }
        }
        Ok(())
    })?;
    Ok(file.finish(progress)?)
}

/// The channel of a bag's topic kept as it is: its schema and encoding, the bag's type as
/// the interface (no Lewis interface reads it), `kind = "original"`.
fn original_spec(topic: &ros2::bag::Topic, source: &str) -> ChannelSpec {
    let mut extra = BTreeMap::new();
    extra.insert(META_KIND.to_owned(), "original".to_owned());
    extra.insert("imported_from".to_owned(), source.to_owned());
    // Without it, the recorder writes the topic's usual QoS.
    if let Some(qos) = &topic.offered_qos {
        extra.insert(OFFERED_QOS_PROFILES.to_owned(), qos.clone());
    }
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
