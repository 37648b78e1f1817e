//! `lewis info`: what an MCAP recording holds, like `mcap info`, plus decoded messages,
//! lost-message counts and the inconsistencies a damaged or odd file has.
//!
//! The summary section is trusted when there is one (so a large file is not read), the
//! file is scanned from the start when there is none or it cannot be read; a file cut short
//! is reported as truncated, with what could be read.

mod render;
mod scan;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_interfaces::dynamic::{Decoder, Value};
use lewis_mcap::format::{self, RECORDING_METADATA};
use lewis_mcap::records::{Channel, Metadata, Statistics};
use lewis_mcap::{McapError, McapFile, OpenError, ReadError};
use serde::Serialize;

use scan::{RawMessage, Scan, ScanGoal, SchemaRecord};

/// The name of the metadata record where the recorder stores lost-message counts
/// (keys: topics, values: decimal counts). When a file has several, the last one counts
/// (the recorder's final tally).
pub const LOSS_METADATA_NAME: &str = format::LOSS_METADATA;

/// What [`inspect`] reads besides the summary.
#[derive(Debug, Clone, Default)]
pub struct InfoOptions {
    /// How many messages to decode and show, from the start of the file.
    pub messages: usize,
    /// Read every record even when the summary has the counts: slower, and checks the
    /// summary against the data.
    pub scan: bool,
}

/// Where the counts of a report come from.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum CountSource {
    /// The Statistics record of the summary section.
    Summary,
    /// A scan of every record of the file.
    Scan,
}

/// One channel of the recording.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelInfo {
    /// The channel id.
    pub id: u16,
    /// The topic.
    pub topic: String,
    /// The schema name (`std_msgs/msg/String`), if the channel has a schema.
    pub schema_name: Option<String>,
    /// The schema encoding (`ros2msg`), if the channel has a schema.
    pub schema_encoding: Option<String>,
    /// The message encoding (`cdr`).
    pub message_encoding: String,
    /// Messages recorded on the channel.
    pub message_count: u64,
    /// Messages per second over the whole recording, when it spans some time.
    pub rate_hz: Option<f64>,
    /// Messages the recorder lost on this topic, when the recording says.
    pub lost_count: Option<u64>,
}

/// Chunks using one compression.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct CompressionCount {
    /// `zstd`, `lz4` or `none`.
    pub compression: String,
    /// How many chunks use it.
    pub chunk_count: u64,
}

/// Something odd about the file that does not stop it from being read.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Warning {
    /// What kind of oddity.
    pub kind: WarningKind,
    /// The details, for a person.
    pub message: String,
}

/// The kinds of [`Warning`].
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum WarningKind {
    /// The Statistics record disagrees with the other records.
    StatisticsMismatch,
    /// The summary section could not be read; the file was scanned instead.
    SummaryUnreadable,
    /// A `lewis.loss` metadata record could not be read.
    BadLossMetadata,
    /// The `lewis.recording` metadata record could not be read.
    BadRecordingMetadata,
}

/// Which versions wrote a Lewis recording, from its `lewis.recording` metadata record.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
#[serde(tag = "kind", rename_all = "snake_case")]
pub enum WrittenBy {
    /// The recording says which versions wrote it.
    Versioned {
        /// The recording format's version (`lewis_mcap::format::FORMAT_VERSION`).
        format_version: u32,
        /// The version of Lewis.
        lewis_version: String,
        /// The digest of the interfaces its messages were encoded with.
        interfaces: String,
    },
    /// A Lewis recording made before recordings said which versions wrote them.
    BeforeVersioning,
}

impl From<format::WrittenBy> for WrittenBy {
    fn from(written: format::WrittenBy) -> Self {
        match written {
            format::WrittenBy::Versioned {
                format_version,
                lewis_version,
                interfaces,
            } => Self::Versioned {
                format_version,
                lewis_version,
                interfaces,
            },
            format::WrittenBy::BeforeVersioning => Self::BeforeVersioning,
        }
    }
}

/// Why the file could not be read to its end.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Damage {
    /// True when the file ends early (no footer, or cut inside a record); false when a
    /// record is corrupt.
    pub truncated: bool,
    /// What the reader met.
    pub detail: String,
    /// What to do about it.
    pub hint: String,
}

/// One decoded message.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct MessageSample {
    /// The channel id.
    pub channel_id: u16,
    /// The channel's topic (empty if the channel is unknown).
    pub topic: String,
    /// The message's sequence number.
    pub sequence: u32,
    /// When it was logged, ns since the epoch.
    pub log_time_ns: u64,
    /// When it was published, ns since the epoch.
    pub publish_time_ns: u64,
    /// The size of the encoded message.
    pub size_bytes: usize,
    /// The decoded value, when it could be decoded.
    #[serde(serialize_with = "crate::json::serialize_optional_value")]
    pub value: Option<Value>,
    /// Why it could not be decoded.
    pub error: Option<String>,
}

/// What `lewis info` tells about a recording. `Display` gives the human form, `Serialize`
/// the JSON one.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct InfoReport {
    /// The file.
    pub path: PathBuf,
    /// Its size.
    pub size_bytes: u64,
    /// The Header's profile (`ros2`).
    pub profile: String,
    /// The Header's library (the writer).
    pub library: String,
    /// Which versions of the format, of Lewis and of the interfaces wrote it; `None` when
    /// Lewis did not write it (no `lewis.recording` metadata).
    pub written_by: Option<WrittenBy>,
    /// Where the counts come from.
    pub source: CountSource,
    /// Messages in the recording.
    pub message_count: u64,
    /// Log time of the first message, ns since the epoch.
    pub start_ns: Option<u64>,
    /// Log time of the last message, ns since the epoch.
    pub end_ns: Option<u64>,
    /// `end_ns - start_ns`.
    pub duration_ns: Option<u64>,
    /// Chunks in the recording.
    pub chunk_count: u64,
    /// Chunks per compression, sorted by compression name.
    pub compressions: Vec<CompressionCount>,
    /// Attachments in the recording.
    pub attachment_count: u64,
    /// The names of the metadata records, in file order.
    pub metadata_names: Vec<String>,
    /// The channels, sorted by id.
    pub channels: Vec<ChannelInfo>,
    /// Lost messages per topic from the `lewis.loss` metadata (empty when absent).
    pub lost_messages: BTreeMap<String, u64>,
    /// Oddities found.
    pub warnings: Vec<Warning>,
    /// Why the file could not be read to its end, if so.
    pub damage: Option<Damage>,
    /// The first messages, decoded, in file order (as many as asked for).
    pub messages: Vec<MessageSample>,
}

/// Why [`inspect`] could not report anything.
#[derive(Debug, thiserror::Error)]
pub enum InfoError {
    /// The file cannot be opened or read.
    #[error("cannot read {}: {source}", path.display())]
    Io {
        /// The file.
        path: PathBuf,
        /// The I/O error.
        source: std::io::Error,
    },
    /// The file does not start like an MCAP file.
    #[error("{} is not an MCAP file: {detail}", path.display())]
    NotMcap {
        /// The file.
        path: PathBuf,
        /// What the reader met instead of an MCAP header.
        detail: String,
    },
}

/// Reports what the MCAP file at `path` holds.
pub fn inspect(path: &Path, options: &InfoOptions) -> Result<InfoReport, InfoError> {
    let io_error = |source| InfoError::Io {
        path: path.to_owned(),
        source,
    };
    let mut file = McapFile::open(path).map_err(|error| match error {
        OpenError::Io(source) => io_error(source),
        OpenError::NotMcap { error, .. } => InfoError::NotMcap {
            path: path.to_owned(),
            detail: error.to_string(),
        },
    })?;
    let size_bytes = file.size_bytes();
    let header = file.header().clone();
    let mut warnings = Vec::new();
    let summary = match file.summary() {
        Ok(summary) => summary,
        Err(ReadError::Io(error)) => return Err(io_error(error)),
        Err(ReadError::Format(error)) => {
            warnings.push(Warning {
                kind: WarningKind::SummaryUnreadable,
                message: format!(
                    "the summary section cannot be read ({error}); the file was scanned"
                ),
            });
            None
        }
    };
    let usable = summary.filter(|summary| {
        summary.stats.as_ref().is_some_and(|stats| {
            stats.message_count == 0 || !stats.channel_message_counts.is_empty()
        })
    });
    let mut builder = Builder {
        path: path.to_owned(),
        size_bytes,
        profile: header.profile,
        library: header.library,
        warnings,
    };
    let report = match usable {
        Some(summary) if !options.scan => builder.report_from_summary(&mut file, &summary, options),
        Some(summary) => {
            let scan = scan::scan(&mut file, full_scan(options)).map_err(io_error)?;
            builder.check_summary_against_scan(&summary, &scan);
            Ok(builder.report_from_scan(scan))
        }
        None => {
            let scan = scan::scan(&mut file, full_scan(options)).map_err(io_error)?;
            Ok(builder.report_from_scan(scan))
        }
    };
    report.map_err(io_error)
}

fn full_scan(options: &InfoOptions) -> ScanGoal {
    ScanGoal {
        keep_messages: options.messages,
        stop_when_kept: false,
    }
}

struct Builder {
    path: PathBuf,
    size_bytes: u64,
    profile: String,
    library: String,
    warnings: Vec<Warning>,
}

impl Builder {
    fn report_from_summary(
        &mut self,
        file: &mut McapFile,
        summary: &lewis_mcap::Summary,
        options: &InfoOptions,
    ) -> std::io::Result<InfoReport> {
        let stats = summary.stats.clone().unwrap_or_default();
        self.check_statistics(summary, &stats);
        let mut compressions: BTreeMap<String, u64> = BTreeMap::new();
        for index in &summary.chunk_indexes {
            *compressions.entry(index.compression.clone()).or_default() += 1;
        }
        let mut metadata_names = Vec::new();
        let mut loss_records = Vec::new();
        let mut recording_records = Vec::new();
        for index in &summary.metadata_indexes {
            metadata_names.push(index.name.clone());
            if index.name == RECORDING_METADATA && recording_records.is_empty() {
                match file.metadata_at(index) {
                    Ok(metadata) => recording_records.push(metadata),
                    Err(ReadError::Io(error)) => return Err(error),
                    Err(ReadError::Format(error)) => self.warnings.push(Warning {
                        kind: WarningKind::BadRecordingMetadata,
                        message: format!(
                            "the `{RECORDING_METADATA}` metadata record at byte {} cannot be read: {error}",
                            index.offset
                        ),
                    }),
                }
            }
            if index.name == LOSS_METADATA_NAME {
                match file.metadata_at(index) {
                    Ok(metadata) => loss_records.push(metadata),
                    Err(ReadError::Io(error)) => return Err(error),
                    Err(ReadError::Format(error)) => self.warnings.push(Warning {
                        kind: WarningKind::BadLossMetadata,
                        message: format!(
                            "the `{LOSS_METADATA_NAME}` metadata record at byte {} cannot be read: {error}",
                            index.offset
                        ),
                    }),
                }
            }
        }
        let schemas = summary
            .schemas
            .iter()
            .map(|(id, schema)| {
                let record = SchemaRecord {
                    name: schema.name.clone(),
                    encoding: schema.encoding.clone(),
                    data: schema.data.to_vec(),
                };
                (*id, record)
            })
            .collect();
        let channels = summary
            .channels
            .iter()
            .map(|(id, channel)| {
                let record = Channel {
                    id: *id,
                    schema_id: channel.schema.as_ref().map_or(0, |schema| schema.id),
                    topic: channel.topic.clone(),
                    message_encoding: channel.message_encoding.clone(),
                    metadata: channel.metadata.clone(),
                };
                (*id, record)
            })
            .collect();
        let (messages, damage) = if options.messages > 0 {
            let goal = ScanGoal {
                keep_messages: options.messages,
                stop_when_kept: true,
            };
            let scan = scan::scan(file, goal)?;
            let damage = scan.failure.as_ref().map(|error| self.damage(error));
            (scan.messages, damage)
        } else {
            (Vec::new(), None)
        };
        let contents = Contents {
            schemas,
            channels,
            message_counts: stats.channel_message_counts.clone(),
            message_count: stats.message_count,
            start_ns: (stats.message_count > 0).then_some(stats.message_start_time),
            end_ns: (stats.message_count > 0).then_some(stats.message_end_time),
            chunk_count: u64::from(stats.chunk_count),
            compressions,
            attachment_count: u64::from(stats.attachment_count),
            metadata_names,
            loss_records,
            recording_records,
            messages,
            damage,
        };
        Ok(self.finish(CountSource::Summary, contents))
    }

    fn report_from_scan(&mut self, scan: Scan) -> InfoReport {
        let damage = match &scan.failure {
            Some(error) => Some(self.damage(error)),
            None if !scan.complete => Some(Damage {
                truncated: true,
                detail: "the file ends without a footer".to_owned(),
                hint: self.hint(),
            }),
            None => None,
        };
        if damage.is_some() {
            // A damaged file has no readable summary; the damage says why, once.
            self.warnings
                .retain(|warning| warning.kind != WarningKind::SummaryUnreadable);
        }
        let metadata_names = scan.metadata.iter().map(|m| m.name.clone()).collect();
        let recording_records = scan
            .metadata
            .iter()
            .filter(|metadata| metadata.name == RECORDING_METADATA)
            .take(1)
            .cloned()
            .collect();
        let loss_records = scan
            .metadata
            .into_iter()
            .filter(|metadata| metadata.name == LOSS_METADATA_NAME)
            .collect();
        let contents = Contents {
            schemas: scan.schemas,
            channels: scan.channels,
            message_counts: scan.message_counts,
            message_count: scan.message_count,
            start_ns: scan.start_ns,
            end_ns: scan.end_ns,
            chunk_count: scan.chunk_count,
            compressions: scan.compressions,
            attachment_count: scan.attachment_count,
            metadata_names,
            loss_records,
            recording_records,
            messages: scan.messages,
            damage,
        };
        self.finish(CountSource::Scan, contents)
    }

    fn hint(&self) -> String {
        format!("run `lewis recover {} -o FIXED.mcap`", self.path.display())
    }

    fn damage(&self, error: &McapError) -> Damage {
        // Records are limited to the file's size, so one "too large" runs past its end.
        let truncated = matches!(
            error,
            McapError::UnexpectedEof
                | McapError::BadMagic
                | McapError::BadFooter
                | McapError::RecordTooLarge { .. }
        ) || matches!(error, McapError::Io(io) if io.kind() == std::io::ErrorKind::UnexpectedEof);
        let detail = match error {
            McapError::UnexpectedEof => "the file ends in the middle of a record".to_owned(),
            McapError::RecordTooLarge { opcode, len } => format!(
                "a record (opcode {opcode:#04x}) of {len} bytes runs past the end of the file"
            ),
            McapError::BadMagic => "the file does not end with the MCAP magic bytes".to_owned(),
            error if truncated => format!("the file ends early ({error})"),
            error => format!("a record cannot be read ({error})"),
        };
        Damage {
            truncated,
            detail,
            hint: self.hint(),
        }
    }

    fn statistics_warning(&mut self, message: String) {
        self.warnings.push(Warning {
            kind: WarningKind::StatisticsMismatch,
            message,
        });
    }

    /// Compares the Statistics record with the other summary records.
    fn check_statistics(&mut self, summary: &lewis_mcap::Summary, stats: &Statistics) {
        let channel_count = summary.channels.len();
        if usize::try_from(stats.channel_count).ok() != Some(channel_count) {
            let without: Vec<String> = sorted(summary.channels.iter())
                .into_iter()
                .filter(|(id, _)| !stats.channel_message_counts.contains_key(id))
                .map(|(id, channel)| format!("{id} {}", channel.topic))
                .collect();
            let detail = if without.is_empty() {
                String::new()
            } else {
                format!(
                    "; channels without a message count in it (counted as 0): {}",
                    without.join(", ")
                )
            };
            self.statistics_warning(format!(
                "the Statistics record counts {} channels but the summary has {channel_count} Channel records{detail}",
                stats.channel_count
            ));
        }
        let schema_count = summary.schemas.len();
        if usize::from(stats.schema_count) != schema_count {
            self.statistics_warning(format!(
                "the Statistics record counts {} schemas but the summary has {schema_count} Schema records",
                stats.schema_count
            ));
        }
        let unknown: Vec<String> = stats
            .channel_message_counts
            .keys()
            .filter(|id| !summary.channels.contains_key(id))
            .map(ToString::to_string)
            .collect();
        if !unknown.is_empty() {
            self.statistics_warning(format!(
                "the Statistics record counts messages of channels that have no Channel record: {}",
                unknown.join(", ")
            ));
        }
        let sum: u64 = stats.channel_message_counts.values().sum();
        if !stats.channel_message_counts.is_empty() && sum != stats.message_count {
            self.statistics_warning(format!(
                "the Statistics record counts {} messages but its channel counts add up to {sum}",
                stats.message_count
            ));
        }
        let chunk_indexes = summary.chunk_indexes.len();
        if chunk_indexes > 0 && usize::try_from(stats.chunk_count).ok() != Some(chunk_indexes) {
            self.statistics_warning(format!(
                "the Statistics record counts {} chunks but the summary indexes {chunk_indexes}",
                stats.chunk_count
            ));
        }
        let metadata_indexes = summary.metadata_indexes.len();
        if metadata_indexes > 0
            && usize::try_from(stats.metadata_count).ok() != Some(metadata_indexes)
        {
            self.statistics_warning(format!(
                "the Statistics record counts {} metadata records but the summary indexes {metadata_indexes}",
                stats.metadata_count
            ));
        }
    }

    /// Compares the summary's counts with what a full scan found.
    fn check_summary_against_scan(&mut self, summary: &lewis_mcap::Summary, scan: &Scan) {
        let Some(stats) = &summary.stats else {
            return;
        };
        self.check_statistics(summary, stats);
        if stats.message_count != scan.message_count {
            self.statistics_warning(format!(
                "the Statistics record counts {} messages but the file holds {}",
                stats.message_count, scan.message_count
            ));
        }
        let mut ids: Vec<u16> = stats.channel_message_counts.keys().copied().collect();
        ids.extend(scan.message_counts.keys().copied());
        ids.sort_unstable();
        ids.dedup();
        for id in ids {
            let said = stats.channel_message_counts.get(&id).copied().unwrap_or(0);
            let found = scan.message_counts.get(&id).copied().unwrap_or(0);
            if said != found {
                self.statistics_warning(format!(
                    "the Statistics record counts {said} messages on channel {id} but the file holds {found}"
                ));
            }
        }
    }

    fn finish(&mut self, source: CountSource, contents: Contents) -> InfoReport {
        let lost_messages = self.losses(&contents.loss_records);
        let written_by = self.written_by(&contents.recording_records);
        let duration_ns = contents
            .start_ns
            .zip(contents.end_ns)
            .map(|(start, end)| end.saturating_sub(start));
        let channels = contents
            .channels
            .values()
            .map(|channel| {
                let schema = contents.schemas.get(&channel.schema_id);
                let message_count = contents
                    .message_counts
                    .get(&channel.id)
                    .copied()
                    .unwrap_or(0);
                ChannelInfo {
                    id: channel.id,
                    topic: channel.topic.clone(),
                    schema_name: schema.map(|schema| schema.name.clone()),
                    schema_encoding: schema.map(|schema| schema.encoding.clone()),
                    message_encoding: channel.message_encoding.clone(),
                    message_count,
                    rate_hz: rate_hz(message_count, duration_ns),
                    lost_count: lost_messages.get(&channel.topic).copied(),
                }
            })
            .collect();
        let messages = decode_messages(&contents.schemas, &contents.channels, contents.messages);
        let compressions = contents
            .compressions
            .into_iter()
            .map(|(compression, chunk_count)| CompressionCount {
                compression: if compression.is_empty() {
                    "none".to_owned()
                } else {
                    compression
                },
                chunk_count,
            })
            .collect();
        InfoReport {
            path: self.path.clone(),
            size_bytes: self.size_bytes,
            profile: self.profile.clone(),
            library: self.library.clone(),
            written_by,
            source,
            message_count: contents.message_count,
            start_ns: contents.start_ns,
            end_ns: contents.end_ns,
            duration_ns,
            chunk_count: contents.chunk_count,
            compressions,
            attachment_count: contents.attachment_count,
            metadata_names: contents.metadata_names,
            channels,
            lost_messages,
            warnings: std::mem::take(&mut self.warnings),
            damage: contents.damage,
            messages,
        }
    }

    /// Who wrote the recording, from its (first) `lewis.recording` record.
    fn written_by(&mut self, records: &[Metadata]) -> Option<WrittenBy> {
        let record = records.first()?;
        match format::WrittenBy::from_entries(&record.metadata) {
            Ok(written) => Some(written.into()),
            Err(message) => {
                self.warnings.push(Warning {
                    kind: WarningKind::BadRecordingMetadata,
                    message,
                });
                None
            }
        }
    }

    /// The loss counts of the last `lewis.loss` record (the recorder's final tally).
    fn losses(&mut self, records: &[Metadata]) -> BTreeMap<String, u64> {
        let mut losses = BTreeMap::new();
        if let Some(last) = records.last() {
            for (topic, count) in &last.metadata {
                match count.trim().parse::<u64>() {
                    Ok(count) => {
                        losses.insert(topic.clone(), count);
                    }
                    Err(_) => self.warnings.push(Warning {
                        kind: WarningKind::BadLossMetadata,
                        message: format!(
                            "the `{LOSS_METADATA_NAME}` count of topic `{topic}` is `{count}`, not a number"
                        ),
                    }),
                }
            }
        }
        losses
    }
}

/// The records a report is built from, whether from the summary or a scan.
struct Contents {
    schemas: BTreeMap<u16, SchemaRecord>,
    channels: BTreeMap<u16, Channel>,
    message_counts: BTreeMap<u16, u64>,
    message_count: u64,
    start_ns: Option<u64>,
    end_ns: Option<u64>,
    chunk_count: u64,
    compressions: BTreeMap<String, u64>,
    attachment_count: u64,
    metadata_names: Vec<String>,
    loss_records: Vec<Metadata>,
    /// The first `lewis.recording` record, if any.
    recording_records: Vec<Metadata>,
    messages: Vec<RawMessage>,
    damage: Option<Damage>,
}

fn sorted<K: Ord + Copy, V>(items: impl Iterator<Item = (K, V)>) -> Vec<(K, V)> {
    let mut items: Vec<(K, V)> = items.collect();
    items.sort_by_key(|(key, _)| *key);
    items
}

/// Messages per second over the recording, as `mcap info` computes it.
fn rate_hz(message_count: u64, duration_ns: Option<u64>) -> Option<f64> {
    let duration_ns = duration_ns.filter(|duration| *duration > 0)?;
    // Counts and durations of real files are far below 2^53: the conversions are exact.
    Some(message_count as f64 * 1e9 / duration_ns as f64)
}

fn decode_messages(
    schemas: &BTreeMap<u16, SchemaRecord>,
    channels: &BTreeMap<u16, Channel>,
    messages: Vec<RawMessage>,
) -> Vec<MessageSample> {
    let mut decoders: BTreeMap<u16, Result<Decoder, String>> = BTreeMap::new();
    messages
        .into_iter()
        .map(|message| {
            let channel = channels.get(&message.channel_id);
            let decoded = match channel {
                None => Err(format!(
                    "channel {} has no Channel record",
                    message.channel_id
                )),
                Some(channel) => decoders
                    .entry(channel.id)
                    .or_insert_with(|| decoder_for(schemas, channel))
                    .as_ref()
                    .map_err(Clone::clone)
                    .and_then(|decoder| decoder.decode(&message.data).map_err(|e| e.to_string())),
            };
            let (value, error) = match decoded {
                Ok(value) => (Some(value), None),
                Err(error) => (None, Some(error)),
            };
            MessageSample {
                channel_id: message.channel_id,
                topic: channel.map(|c| c.topic.clone()).unwrap_or_default(),
                sequence: message.sequence,
                log_time_ns: message.log_time_ns,
                publish_time_ns: message.publish_time_ns,
                size_bytes: message.data.len(),
                value,
                error,
            }
        })
        .collect()
}

fn decoder_for(
    schemas: &BTreeMap<u16, SchemaRecord>,
    channel: &Channel,
) -> Result<Decoder, String> {
    let schema = schemas
        .get(&channel.schema_id)
        .ok_or_else(|| format!("channel {} has no schema", channel.id))?;
    if schema.encoding != "ros2msg" || channel.message_encoding != "cdr" {
        return Err(format!(
            "{} messages with {} schemas are not decoded (only cdr with ros2msg)",
            channel.message_encoding, schema.encoding
        ));
    }
    let text = std::str::from_utf8(&schema.data)
        .map_err(|_| format!("the schema `{}` is not UTF-8 text", schema.name))?;
    Decoder::new(&schema.name, text).map_err(|error| error.to_string())
}
