//! The recorder core: registered channels and messages in, MCAP files out, with loss
//! accounting, timed flushes, rotation and a clean stop on a full disk. It runs on one
//! thread, reads no clock (times come from the caller) and never blocks on anything but
//! the file; [`crate::spawn`] puts it behind a bounded queue.

use std::collections::{BTreeMap, HashMap};
use std::path::{Path, PathBuf};

use lewis_interfaces::msg::{Header, RecorderStats};
use lewis_interfaces::{Interface, Struct, cdr};
use lewis_mcap::format::WrittenBy;
use mcap::records::Metadata;

use crate::channel::{ChannelId, ChannelSpec, Sample};
use crate::companion::{Companion, Companions, Skipped};
use crate::error::RecordError;
use crate::index::{self, PartEntry, PartsIndex};
use crate::loss::{ChannelCounts, Observation, SequenceTracker};
use crate::options::{RecorderOptions, RobotDescription};
use crate::part::{Part, metadata};

/// The topic of the recorder's own accounting ([`RecorderStats`]).
pub const STATS_TOPIC: &str = "/lewis/recorder/stats";
pub use lewis_mcap::format::{
    INTERFACES_METADATA, LOSS_METADATA, RECORDING_METADATA, ROBOT_METADATA,
};

/// What a closed recording holds.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct RecordingReport {
    /// The files written, in order (one unless rotated).
    pub parts: Vec<PathBuf>,
    /// The parts index, when rotated.
    pub index: Option<PathBuf>,
    /// Counts over the whole recording, per topic.
    pub counts: BTreeMap<String, ChannelCounts>,
}

impl RecordingReport {
    /// Messages written, over all topics and parts (the recorder's stats excluded).
    #[must_use]
    pub fn messages(&self) -> u64 {
        self.counts.values().map(|c| c.written).sum()
    }

    /// Messages known lost, over all topics and parts.
    #[must_use]
    pub fn lost(&self) -> u64 {
        self.counts.values().map(|c| c.lost).sum()
    }
}

struct ChannelState {
    spec: ChannelSpec,
    tracker: SequenceTracker,
    part: ChannelCounts,
    total: ChannelCounts,
}

/// Writes one recording (one file, or a rotated set of parts). See the crate docs.
pub struct Recorder {
    options: RecorderOptions,
    channels: Vec<ChannelState>,
    part: Option<Part>,
    part_number: u32,
    index: Option<(PathBuf, PartsIndex)>,
    parts: Vec<PathBuf>,
    file_metadata: Vec<Metadata>,
    stats_spec: ChannelSpec,
    stats_seq: u64,
    last_flush_ns: Option<i64>,
    last_stats_ns: Option<i64>,
    last_time_ns: Option<i64>,
    durable_before_part: u64,
    stopped: bool,
    closing: bool,
    companions: Option<CompanionWriter>,
}

/// The companion channels' state: what makes them, their channels and numbers.
struct CompanionWriter {
    companions: Companions,
    channels: HashMap<String, (ChannelId, u64)>,
    out: Vec<Companion>,
}

impl Recorder {
    /// Opens the recording: creates the first file (and the parts index when rotating),
    /// and writes the file metadata.
    ///
    /// # Errors
    /// [`RecordError::MissingFolder`], [`RecordError::ReadOnly`],
    /// [`RecordError::AlreadyExists`], [`RecordError::DiskFull`] (no room for the
    /// reserve), or another [`RecordError::Io`].
    pub fn create(options: RecorderOptions) -> Result<Self, RecordError> {
        let index = options
            .splits()
            .then(|| (index::index_path(&options.path), PartsIndex::new()));
        let file_metadata = file_metadata(&options);
        let stats_spec = ChannelSpec {
            topic: STATS_TOPIC.to_owned(),
            schema_name: RecorderStats::SCHEMA_NAME.to_owned(),
            schema_text: RecorderStats::SCHEMA_TEXT.to_owned(),
            provider: options.recorder_name.clone(),
            interface: RecorderStats::NAME.to_owned(),
            interface_version: RecorderStats::VERSION.to_owned(),
            extra_metadata: BTreeMap::new(),
        };
        let companions = options.companions.map(|c| CompanionWriter {
            companions: Companions::new(
                c,
                options.robot_description.as_ref().map(|r| r.toml.as_str()),
            ),
            channels: HashMap::new(),
            out: Vec::new(),
        });
        let mut recorder = Self {
            options,
            channels: Vec::new(),
            part: None,
            part_number: 0,
            index,
            parts: Vec::new(),
            file_metadata,
            stats_spec,
            stats_seq: 0,
            last_flush_ns: None,
            last_stats_ns: None,
            last_time_ns: None,
            durable_before_part: 0,
            stopped: false,
            closing: false,
            companions,
        };
        recorder.open_part()?;
        Ok(recorder)
    }

    /// Registers a channel; its first message may follow at once.
    ///
    /// # Errors
    /// When the file cannot take it (65535 channels at most; an I/O error).
    pub fn add_channel(&mut self, spec: ChannelSpec) -> Result<ChannelId, RecordError> {
        self.ensure_running()?;
        let id = ChannelId(u32::try_from(self.channels.len()).unwrap_or(u32::MAX));
        let result = match &mut self.part {
            Some(part) => part.add_channel(&spec),
            None => Ok(()),
        };
        self.channels.push(ChannelState {
            spec,
            tracker: SequenceTracker::default(),
            part: ChannelCounts::default(),
            total: ChannelCounts::default(),
        });
        self.guard(result)?;
        Ok(id)
    }

    /// The channels registered, in order (the index is the [`ChannelId`]).
    pub fn channels(&self) -> impl Iterator<Item = &ChannelSpec> {
        self.channels.iter().map(|c| &c.spec)
    }

    /// How many channels are registered.
    #[must_use]
    pub fn channel_count(&self) -> usize {
        self.channels.len()
    }

    /// Writes one message: accounts for its sequence number, rotates, closes the chunk
    /// when it is full or when a flush period of receive time has passed, and writes the
    /// stats message when due.
    ///
    /// # Errors
    /// [`RecordError::UnknownChannel`]; [`RecordError::DiskFull`] or
    /// [`RecordError::FileTooLarge`] (the file is then closed); another write error. After
    /// an error the recorder is stopped.
    pub fn write(&mut self, sample: &Sample<'_>) -> Result<(), RecordError> {
        self.ensure_running()?;
        let index = usize::try_from(sample.channel.0).unwrap_or(usize::MAX);
        if index >= self.channels.len() {
            return Err(RecordError::UnknownChannel {
                channel: sample.channel,
            });
        }
        self.rotate_if_due(sample.log_time_ns)?;
        let own_chunk = is_large(sample.data.len(), self.options.chunk_size_bytes);
        if own_chunk {
            self.close_open_chunk()?;
        }
        let channel = &mut self.channels[index];
        let observation = if channel.spec.gaps_are_losses() {
            channel.tracker.observe(sample.seq)
        } else {
            Observation::Next
        };
        channel.part.add(observation);
        channel.total.add(observation);
        let result = match &mut self.part {
            // The MCAP sequence field is 32 bits: the full number is in the CDR header.
            Some(part) => part.write(
                index + 1,
                sample.seq as u32,
                sample.publish_time_ns,
                sample.log_time_ns,
                sample.data,
            ),
            None => Ok(()),
        };
        self.guard(result)?;
        if own_chunk
            || self
                .part
                .as_ref()
                .is_some_and(|p| p.chunk_full(self.options.chunk_size_bytes))
        {
            self.flush_part(false)?;
        }
        self.write_companions(index, sample)?;
        self.timers(sample.log_time_ns)
    }

    /// Writes the companions of the message just written on channel `index`.
    fn write_companions(&mut self, index: usize, sample: &Sample<'_>) -> Result<(), RecordError> {
        // Taken out while its messages are written, so that they make none of their own.
        let Some(mut writer) = self.companions.take() else {
            return Ok(());
        };
        let stamp_ns = if sample.publish_time_ns == 0 {
            sample.log_time_ns
        } else {
            sample.publish_time_ns
        };
        writer.companions.convert(
            &self.channels[index].spec,
            sample.data,
            stamp_ns,
            &mut writer.out,
        );
        let part_number = self.part_number;
        let mut result = Ok(());
        for companion in writer.out.drain(..) {
            let (channel, seq) = match writer.channels.get_mut(&companion.topic) {
                Some(entry) => {
                    entry.1 += 1;
                    *entry
                }
                None => match self.add_channel(companion.channel_spec()) {
                    Ok(id) => *writer
                        .channels
                        .entry(companion.topic.clone())
                        .or_insert((id, 1)),
                    Err(e) => {
                        result = Err(e);
                        break;
                    }
                },
            };
            result = self.write(&Sample {
                channel,
                seq,
                publish_time_ns: sample.publish_time_ns,
                log_time_ns: sample.log_time_ns,
                data: &companion.data,
            });
            if result.is_err() {
                break;
            }
        }
        writer.out.clear();
        if self.part_number != part_number {
            writer.companions.part_started();
        }
        self.companions = Some(writer);
        result
    }

    /// Messages that got no companion channel message, by topic (`None`: companions off).
    #[must_use]
    pub fn companion_skips(&self) -> Option<&BTreeMap<String, Skipped>> {
        self.companions.as_ref().map(|w| w.companions.skipped())
    }

    /// Closes the open chunk if anything is in it, so that what comes next starts a chunk.
    fn close_open_chunk(&mut self) -> Result<(), RecordError> {
        let result = match &mut self.part {
            Some(part) if part.chunk_has_data() => part.flush(false),
            _ => Ok(()),
        };
        self.guard(result)
    }

    /// Counts `count` messages of `channel` that the queue in front of the recorder
    /// dropped (they also show as sequence gaps).
    pub fn note_dropped(&mut self, channel: ChannelId, count: u64) {
        self.count(channel, |counts| counts.dropped += count);
    }

    /// Counts `count` messages of `channel` that its provider sent before it died and that
    /// never arrived: lost, though no sequence gap shows them.
    pub fn note_lost_at_exit(&mut self, channel: ChannelId, count: u64) {
        self.count(channel, |counts| counts.lost += count);
    }

    /// Adds to `channel`'s counts, of this part and of the whole recording.
    fn count(&mut self, channel: ChannelId, add: impl Fn(&mut ChannelCounts)) {
        if let Some(state) = usize::try_from(channel.0)
            .ok()
            .and_then(|i| self.channels.get_mut(i))
        {
            add(&mut state.part);
            add(&mut state.total);
        }
    }

    /// Stores the robot description from now on, for a robot found after the recording
    /// started: written at once into the current file (`lewis.robot`, which closes the
    /// open chunk) and into every later part.
    ///
    /// # Errors
    /// As [`Self::write`].
    pub fn set_robot_description(&mut self, robot: RobotDescription) -> Result<(), RecordError> {
        self.ensure_running()?;
        let record = robot_metadata(&robot);
        if let Some(writer) = &mut self.companions {
            writer.companions.set_robot(&robot.toml);
        }
        self.options.robot_description = Some(robot);
        self.file_metadata = file_metadata(&self.options);
        let result = match &mut self.part {
            Some(part) => part.write_metadata(&record),
            None => Ok(()),
        };
        self.guard(result)
    }

    /// Lets time pass with no message: flushes, writes stats and rotates by duration
    /// when due. `now_ns` is on the clock of the receive times.
    ///
    /// # Errors
    /// As [`Self::write`].
    pub fn tick(&mut self, now_ns: i64) -> Result<(), RecordError> {
        self.ensure_running()?;
        self.rotate_if_due(now_ns)?;
        self.timers(now_ns)
    }

    /// Closes the open chunk and syncs the file: everything written so far survives a
    /// crash of the recorder.
    ///
    /// # Errors
    /// As [`Self::write`].
    pub fn flush(&mut self) -> Result<(), RecordError> {
        self.ensure_running()?;
        self.flush_part(true)
    }

    /// Messages of the recording (all parts) that are in closed chunks handed to the
    /// system: a crash of the recorder now loses none of them.
    #[must_use]
    pub fn durable_messages(&self) -> u64 {
        self.durable_before_part + self.part.as_ref().map_or(0, |p| p.durable_messages)
    }

    /// The counts so far, per topic, over the whole recording.
    #[must_use]
    pub fn counts(&self) -> BTreeMap<String, ChannelCounts> {
        by_topic(self.channels.iter().map(|c| (&c.spec.topic, c.total)))
    }

    /// The file being written.
    #[must_use]
    pub fn current_path(&self) -> &Path {
        self.part.as_ref().map_or(&self.options.path, |p| p.path())
    }

    /// The options it was opened with.
    #[must_use]
    pub fn options(&self) -> &RecorderOptions {
        &self.options
    }

    /// Closes the recording: the last stats message, the `lewis.loss` metadata, the
    /// summary and footer; the parts index is completed.
    ///
    /// # Errors
    /// When the last file cannot be closed, or the recorder had stopped after an error.
    pub fn close(mut self) -> Result<RecordingReport, RecordError> {
        self.ensure_running()?;
        self.close_part()?;
        self.stopped = true;
        Ok(RecordingReport {
            parts: self.parts.clone(),
            index: self.index.as_ref().map(|(path, _)| path.clone()),
            counts: self.counts(),
        })
    }

    fn ensure_running(&self) -> Result<(), RecordError> {
        if self.stopped {
            Err(RecordError::Stopped {
                path: self.current_path().to_path_buf(),
            })
        } else {
            Ok(())
        }
    }

    /// Stops on an error; when the file has no more room (seen in `result`, or by the
    /// file's reserve or headroom below the file size limit), closes the file first.
    fn guard(&mut self, result: Result<(), RecordError>) -> Result<(), RecordError> {
        if self.closing {
            return result;
        }
        let no_room = match &result {
            Err(error) => error.no_room_reason(),
            Ok(()) => None,
        }
        .or_else(|| self.part.as_ref().and_then(Part::no_room));
        if let Some(why) = no_room {
            let path = self.current_path().to_path_buf();
            // The MCAP writer refuses everything after a failed write: only a full file
            // caught by the reserve or the headroom (no failed write) can still be closed.
            let closed_valid = result.is_ok() && self.close_part().is_ok();
            self.part = None;
            self.stopped = true;
            return Err(RecordError::no_room(why, path, closed_valid));
        }
        if result.is_err() {
            self.stopped = true;
        }
        result
    }

    fn timers(&mut self, now_ns: i64) -> Result<(), RecordError> {
        let last_flush = *self.last_flush_ns.get_or_insert(now_ns);
        if now_ns.saturating_sub(last_flush) >= self.options.flush_period_ns {
            self.flush_part(true)?;
            self.last_flush_ns = Some(now_ns);
        }
        let last_stats = *self.last_stats_ns.get_or_insert(now_ns);
        if now_ns.saturating_sub(last_stats) >= self.options.stats_period_ns {
            self.write_stats(now_ns)?;
            self.last_stats_ns = Some(now_ns);
        }
        self.last_time_ns = Some(self.last_time_ns.map_or(now_ns, |t| t.max(now_ns)));
        Ok(())
    }

    fn flush_part(&mut self, sync: bool) -> Result<(), RecordError> {
        let result = match &mut self.part {
            Some(part) if part.has_pending() || sync => part.flush(sync),
            _ => Ok(()),
        };
        self.guard(result)
    }

    fn rotate_if_due(&mut self, now_ns: i64) -> Result<(), RecordError> {
        let Some(part) = &self.part else {
            return Ok(());
        };
        let by_size = self
            .options
            .split_size_bytes
            .is_some_and(|limit| part.messages > 0 && part.size_bytes() >= limit);
        let by_time = self.options.split_duration_ns.is_some_and(|limit| {
            part.first_log_time_ns
                .is_some_and(|first| now_ns.saturating_sub(first) >= limit)
        });
        if by_size || by_time {
            let result = self.close_part().and_then(|()| {
                self.part_number += 1;
                self.open_part()
            });
            if result.is_err() {
                self.stopped = true;
            }
            return result;
        }
        Ok(())
    }

    fn part_path(&self) -> PathBuf {
        if self.index.is_some() {
            index::part_path(&self.options.path, self.part_number)
        } else {
            self.options.path.clone()
        }
    }

    fn open_part(&mut self) -> Result<(), RecordError> {
        let path = self.part_path();
        let mut metadata = self.file_metadata.clone();
        metadata.push(self.recording_metadata());
        let mut part = Part::create(&path, &self.options, &metadata)?;
        part.add_channel(&self.stats_spec)?;
        for channel in &mut self.channels {
            part.add_channel(&channel.spec)?;
            channel.part = ChannelCounts::default();
        }
        self.part = Some(part);
        self.parts.push(path.clone());
        if let Some(writer) = &mut self.companions {
            writer.companions.part_started();
        }
        if let Some((index_path, index)) = &mut self.index {
            index.parts.push(PartEntry {
                file: file_name(&path),
                complete: false,
                message_count: 0,
                first_log_time_ns: None,
                last_log_time_ns: None,
            });
            write_index(index_path, index)?;
        }
        Ok(())
    }

    fn close_part(&mut self) -> Result<(), RecordError> {
        let was_closing = std::mem::replace(&mut self.closing, true);
        let result = self.close_part_inner();
        self.closing = was_closing;
        if result.is_err() {
            self.part = None;
            self.stopped = true;
        }
        result
    }

    fn close_part_inner(&mut self) -> Result<(), RecordError> {
        let Some(part) = &self.part else {
            return Ok(());
        };
        // Not before the last periodic stats: the stats channel's times must not go back
        // (`rerun mcap check` reports a channel whose chunks are out of order).
        let now_ns = part
            .last_log_time_ns
            .or(self.last_time_ns)
            .unwrap_or_default()
            .max(self.last_stats_ns.unwrap_or(i64::MIN));
        self.write_stats(now_ns)?;
        let loss = metadata(
            LOSS_METADATA,
            self.part_counts()
                .into_iter()
                .map(|(topic, counts)| (topic, counts.lost.to_string()))
                .collect(),
        );
        let Some(mut part) = self.part.take() else {
            return Ok(());
        };
        part.write_metadata(&loss)?;
        let entry = PartEntry {
            file: file_name(part.path()),
            complete: true,
            message_count: part.messages,
            first_log_time_ns: part.first_log_time_ns,
            last_log_time_ns: part.last_log_time_ns,
        };
        self.durable_before_part += part.messages;
        part.finish()?;
        if let Some((index_path, index)) = &mut self.index {
            if let Some(last) = index.parts.last_mut() {
                *last = entry;
            }
            write_index(index_path, index)?;
        }
        Ok(())
    }

    fn part_counts(&self) -> BTreeMap<String, ChannelCounts> {
        by_topic(self.channels.iter().map(|c| (&c.spec.topic, c.part)))
    }

    fn write_stats(&mut self, now_ns: i64) -> Result<(), RecordError> {
        let Some(part) = &self.part else {
            return Ok(());
        };
        let counts = self.part_counts();
        let as_i64 = |n: u64| i64::try_from(n).unwrap_or(i64::MAX);
        self.stats_seq += 1;
        let stats = RecorderStats {
            header: Header {
                provider: self.options.recorder_name.clone(),
                seq: self.stats_seq,
                publish_time_ns: now_ns,
                inputs: Vec::new(),
            },
            file: self
                .options
                .file_label
                .clone()
                .unwrap_or_else(|| file_name(part.path())),
            topic_count: i32::try_from(counts.len()).unwrap_or(i32::MAX),
            topics: counts.keys().cloned().collect(),
            written: counts.values().map(|c| as_i64(c.written)).collect(),
            lost: counts.values().map(|c| as_i64(c.lost)).collect(),
            dropped: counts.values().map(|c| as_i64(c.dropped)).collect(),
            restarts: counts.values().map(|c| as_i64(c.restarts)).collect(),
        };
        let bytes = cdr::to_vec(&stats);
        let sequence = self.stats_seq as u32;
        let result = match &mut self.part {
            Some(part) => part.write(0, sequence, now_ns, now_ns, &bytes),
            None => Ok(()),
        };
        self.guard(result)
    }

    fn recording_metadata(&self) -> Metadata {
        // Every crate of Lewis has the workspace's version: the recorder's is Lewis's.
        let mut entries =
            WrittenBy::current(env!("CARGO_PKG_VERSION"), &interface_files()).entries();
        entries.extend([
            (
                "recorder".to_owned(),
                format!("lewis-recorder {}", env!("CARGO_PKG_VERSION")),
            ),
            ("part".to_owned(), self.part_number.to_string()),
            ("stats_topic".to_owned(), STATS_TOPIC.to_owned()),
        ]);
        if let Some((index_path, _)) = &self.index {
            entries.insert("parts_index".to_owned(), file_name(index_path));
        }
        metadata(RECORDING_METADATA, entries)
    }
}

/// Sums counts of channels that share a topic.
fn by_topic<'a>(
    channels: impl Iterator<Item = (&'a String, ChannelCounts)>,
) -> BTreeMap<String, ChannelCounts> {
    let mut counts: BTreeMap<String, ChannelCounts> = BTreeMap::new();
    for (topic, c) in channels {
        let sum = counts.entry(topic.clone()).or_default();
        sum.written += c.written;
        sum.lost += c.lost;
        sum.dropped += c.dropped;
        sum.restarts += c.restarts;
    }
    counts
}

/// The metadata every file carries: the interface XML and the robot description.
/// The entries of `lewis.interfaces`: every interface XML and `types.xml`, by file name.
fn interface_files() -> BTreeMap<String, String> {
    lewis_interfaces::msg::TYPES_XML
        .iter()
        .map(|(file, xml)| ((*file).to_owned(), (*xml).to_owned()))
        .chain(
            lewis_interfaces::msg::INTERFACES
                .iter()
                .map(|i| (format!("{}.xml", i.name), i.xml.to_owned())),
        )
        .collect()
}

fn file_metadata(options: &RecorderOptions) -> Vec<Metadata> {
    let mut records = vec![metadata(INTERFACES_METADATA, interface_files())];
    if let Some(robot) = &options.robot_description {
        records.push(robot_metadata(robot));
    }
    records
}

/// `lewis.robot`: the robot description keyed by its file name.
fn robot_metadata(robot: &RobotDescription) -> Metadata {
    metadata(
        ROBOT_METADATA,
        BTreeMap::from([(robot.file_name.clone(), robot.toml.clone())]),
    )
}

fn file_name(path: &Path) -> String {
    path.file_name()
        .map(|n| n.to_string_lossy().into_owned())
        .unwrap_or_default()
}

fn write_index(path: &Path, index: &PartsIndex) -> Result<(), RecordError> {
    index
        .write(path)
        .map_err(|source| RecordError::opening(path, source))
}

/// A message of at least a quarter of a chunk (a camera frame) is written in a chunk of its
/// own. MCAP readers pick the chunks to decompress by the channels in them (the chunk
/// indexes list them), so a reader of the other topics (the replay's recorded mission, a
/// plot of odometry) then never decompresses a frame; mixed in, every chunk held one.
fn is_large(bytes: usize, chunk_size_bytes: u64) -> bool {
    u64::try_from(bytes).unwrap_or(u64::MAX) >= chunk_size_bytes / 4 && chunk_size_bytes > 0
}
