//! `lewis export ros2 RUN.mcap -o OUT.mcap`: a Lewis recording copied, every channel and
//! message unchanged, with the recorder's companion channels of ROS 2's standard types
//! beside them ([`lewis_recorder::companion`]: LaserScan, PointCloud2, Odometry, tf,
//! markers, and CompressedImage when asked), so that Foxglove's 3D panel draws the robot.
//! It is how a recording made with companions off (or by an older Lewis) gets them.
//!
//! Companion channels already in the input are made again rather than copied, and the
//! input's recorder stats (`/lewis/recorder/stats`) give way to the export's own; the
//! copied channels' sequence numbers are kept, so their losses are counted again in the
//! output's `lewis.loss`. The file is written through the recorder to a temporary file
//! beside the output and renamed once complete: nothing is left under the output's name
//! when the export fails.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::sync::Arc;

use lewis_interfaces::Struct;
use lewis_interfaces::msg::ImageSource;
use lewis_recorder::companion::{COMPANION_KIND, CompanionOptions, Skipped, has_view};
use lewis_recorder::live::META_KIND;
use lewis_recorder::{
    ChannelId, RecordError, Recorder, RecorderOptions, RecordingReport, RobotDescription,
    STATS_TOPIC, Sample,
};

use crate::whole_file::{RenameError, write_whole};
use lewis_recording::{RecordingError, RecordingFiles, Topic};

/// The provider of the export's recorder stats.
pub const EXPORT_PROVIDER: &str = "lewis-export";

/// Why an export failed.
#[derive(Debug, thiserror::Error)]
pub enum ExportError {
    /// The input is not a readable recording.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// The recorder refused.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// The output exists.
    #[error("{} exists: give another -o, or remove it first", path.display())]
    Exists {
        /// The output.
        path: PathBuf,
    },
    /// Nothing in the input has a ROS 2 view.
    #[error(
        "{}: no channel of RangeFinder, Egomotion, Blobs3D, Signs, Broker or ImageSource: nothing to export (is it a Lewis recording?)",
        path.display()
    )]
    NothingToExport {
        /// The input.
        path: PathBuf,
    },
    /// The finished file could not be moved to its name.
    #[error(transparent)]
    Rename(#[from] RenameError),
}

/// What was written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct ExportReport {
    /// The file and the counts per topic.
    pub recording: RecordingReport,
    /// Messages copied from the input.
    pub copied: u64,
    /// Messages written per companion topic, with its ROS 2 type.
    pub companions: BTreeMap<String, (String, u64)>,
    /// ImageSource messages left out (images not asked for), per topic.
    pub images_left_out: BTreeMap<String, u64>,
    /// Messages that got no companion, and why, per topic.
    pub skipped: BTreeMap<String, Skipped>,
}

/// Exports `input` (one file or a parts index) to `output` (see the module).
///
/// # Errors
/// The input is not a readable recording or has nothing to convert, the output exists, or
/// the recorder refuses. Nothing is left under `output` on failure.
pub fn export(
    input: &Path,
    output: &Path,
    options: CompanionOptions,
) -> Result<ExportReport, ExportError> {
    if output.exists() {
        return Err(ExportError::Exists {
            path: output.to_owned(),
        });
    }
    let recording = RecordingFiles::open(&[input.to_owned()])?;
    let converted = recording
        .topics()
        .values()
        .any(|t| !is_companion(t) && has_view(&t.schema_name));
    if !converted {
        return Err(ExportError::NothingToExport {
            path: input.to_owned(),
        });
    }
    let mut report = write_whole(output, |path| export_to(&recording, path, options))?;
    report.recording.parts = vec![output.to_owned()];
    Ok(report)
}

fn is_companion(topic: &Topic) -> bool {
    topic.metadata.get(META_KIND).map(String::as_str) == Some(COMPANION_KIND)
}

fn export_to(
    recording: &RecordingFiles,
    path: &Path,
    options: CompanionOptions,
) -> Result<ExportReport, ExportError> {
    let mut recorder_options = RecorderOptions::new(path);
    recorder_options.sync_on_flush = false;
    recorder_options.robot_description =
        recording
            .robot_toml()
            .map(|(file_name, toml)| RobotDescription {
                file_name: file_name.to_owned(),
                toml: toml.to_owned(),
            });
    EXPORT_PROVIDER.clone_into(&mut recorder_options.recorder_name);
    recorder_options.companions = Some(options);
    let mut recorder = Recorder::create(recorder_options)?;
    let mut channels: BTreeMap<Arc<str>, Option<ChannelId>> = BTreeMap::new();
    let mut copied = 0;
    // From the summaries' counts: no work per message.
    let images_left_out = if options.images.is_none() {
        recording
            .topics()
            .values()
            .filter(|t| !is_companion(t) && t.schema_name == ImageSource::SCHEMA_NAME)
            .map(|t| (t.name.to_string(), t.message_count))
            .collect()
    } else {
        BTreeMap::new()
    };
    for message in recording.messages()? {
        let message = message?;
        let channel = match channels.get(&message.topic) {
            Some(channel) => *channel,
            None => {
                let channel = match recording.topics().get(&message.topic) {
                    Some(topic) if !is_companion(topic) && &*topic.name != STATS_TOPIC => {
                        Some(recorder.add_channel(topic.channel_spec())?)
                    }
                    _ => None,
                };
                channels.insert(message.topic.clone(), channel);
                channel
            }
        };
        let Some(channel) = channel else { continue };
        recorder.write(&Sample {
            channel,
            seq: message.seq,
            publish_time_ns: message.publish_time_ns,
            log_time_ns: message.log_time_ns,
            data: &message.data,
        })?;
        copied += 1;
    }
    let skipped = recorder.companion_skips().cloned().unwrap_or_default();
    let companions = recorder
        .channels()
        .filter(|c| c.extra_metadata.get(META_KIND).map(String::as_str) == Some(COMPANION_KIND))
        .map(|c| (c.topic.clone(), c.schema_name.clone()))
        .collect::<Vec<_>>();
    let recording = recorder.close()?;
    let companions = companions
        .into_iter()
        .map(|(topic, type_name)| {
            let count = recording.counts.get(&topic).map_or(0, |c| c.written);
            (topic, (type_name, count))
        })
        .collect();
    Ok(ExportReport {
        recording,
        copied,
        companions,
        images_left_out,
        skipped,
    })
}
