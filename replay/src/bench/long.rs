//! `lewis bench long-recording REF.mcap -o LONG.mcap --size-mb N`: a recording of at least N
//! MB made by playing a short one again and again, each lap one second after the last, so
//! that a replay of a gigabyte can be measured (its peak memory must not grow with the
//! length).
//!
//! Each lap is the reference shifted in time: log and publish times, and the publish time in
//! each message's header (so that what services compute from sample times, like the age of
//! a reading, goes on as in a live run); the bytes are otherwise unchanged. A lap starts as
//! the reference did (the goal sent again, the odometry back at the start), so the services
//! of a replay, which go on from one lap to the next, diverge from the laps after the first:
//! a long recording measures memory and speed, not exactness.

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_interfaces::cdr;
use lewis_recorder::{
    ChannelId, RecordError, Recorder, RecorderOptions, RobotDescription, STATS_TOPIC, Sample,
};

use lewis_recording::{Recording, RecordingError};

/// Time between the end of one lap and the start of the next.
pub const LAP_GAP_NS: i64 = 1_000_000_000;

/// What was written.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct LongReport {
    /// The file.
    pub output: PathBuf,
    /// Laps written.
    pub laps: u64,
    /// Messages written.
    pub messages: u64,
    /// The file's size.
    pub bytes: u64,
    /// The recording's length.
    pub duration_ns: i64,
}

/// Why a long recording cannot be made.
#[derive(Debug, thiserror::Error)]
pub enum LongError {
    /// The reference cannot be read.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// The output cannot be written.
    #[error("writing {path}: {source}")]
    Record {
        /// The output.
        path: PathBuf,
        /// What went wrong.
        source: RecordError,
    },
    /// The output is the reference.
    #[error("the output {0} is the reference itself: choose another with -o")]
    OutputIsInput(PathBuf),
    /// The reference holds no message.
    #[error("{0} holds no message to repeat")]
    Empty(PathBuf),
}

/// Writes `output` from laps of `input` until it holds at least `min_bytes` (estimated from
/// the reference's size); `progress` hears of each lap written, and of how many there will
/// be.
///
/// # Errors
/// When the reference cannot be read or the output written.
pub fn write_long(
    input: &Path,
    output: &Path,
    min_bytes: u64,
    progress: &mut dyn FnMut(u64, u64),
) -> Result<LongReport, LongError> {
    if input.canonicalize().ok() == output.canonicalize().ok() && output.exists() {
        return Err(LongError::OutputIsInput(output.to_path_buf()));
    }
    let recording = Recording::open(&[input.to_path_buf()])?;
    let input_bytes = std::fs::metadata(input)
        .map_err(|error| RecordingError::Io {
            path: input.to_path_buf(),
            error,
        })?
        .len()
        .max(1);
    if recording.message_count() == 0 {
        return Err(LongError::Empty(input.to_path_buf()));
    }
    let laps = min_bytes.div_ceil(input_bytes).max(1);
    let lap_ns = recording.end_ns() - recording.start_ns() + LAP_GAP_NS;
    let record_error = |source| LongError::Record {
        path: output.to_path_buf(),
        source,
    };
    let (file_name, toml) = recording.robot_toml();
    let mut options = RecorderOptions::new(output);
    options.robot_description = Some(RobotDescription {
        file_name: file_name.to_owned(),
        toml: toml.to_owned(),
    });
    options.sync_on_flush = false;
    options.disk_reserve_bytes = 0;
    let mut recorder = Recorder::create(options).map_err(record_error)?;
    let mut channels: BTreeMap<String, ChannelId> = BTreeMap::new();
    for topic in recording.topics().values() {
        if &*topic.name == STATS_TOPIC {
            continue;
        }
        let id = recorder
            .add_channel(topic.channel_spec())
            .map_err(record_error)?;
        channels.insert(topic.name.to_string(), id);
    }
    let mut messages = 0u64;
    for lap in 0..laps {
        let shift = lap_ns.saturating_mul(i64::try_from(lap).unwrap_or(i64::MAX));
        for message in recording.messages()? {
            let message = message?;
            let Some(channel) = channels.get(&*message.topic) else {
                continue;
            };
            let mut data = message.data.to_vec();
            shift_header_time(&mut data, shift);
            let shifted = |t: i64| if t > 0 { t.saturating_add(shift) } else { t };
            recorder
                .write(&Sample {
                    channel: *channel,
                    seq: message.seq,
                    publish_time_ns: shifted(message.publish_time_ns),
                    log_time_ns: shifted(message.log_time_ns),
                    data: &data,
                })
                .map_err(record_error)?;
            messages += 1;
        }
        progress(lap + 1, laps);
    }
    recorder.close().map_err(record_error)?;
    let bytes = std::fs::metadata(output).map_or(0, |m| m.len());
    Ok(LongReport {
        output: output.to_path_buf(),
        laps,
        messages,
        bytes,
        duration_ns: lap_ns.saturating_mul(i64::try_from(laps).unwrap_or(i64::MAX)),
    })
}

/// Moves the publish time in the header at the start of a CDR message by `shift_ns`
/// (a message without a valid header, or with no time, is left as it is).
fn shift_header_time(data: &mut [u8], shift_ns: i64) {
    let Ok(mut header) = cdr::peek_header(data) else {
        return;
    };
    if header.publish_time_ns > 0 {
        header.publish_time_ns = header.publish_time_ns.saturating_add(shift_ns);
        // Only the time changed, so the header keeps its length and cannot be refused; a
        // refusal would leave the message as it is, as for a message without a header.
        let _ = cdr::replace_header(data, &header);
    }
}

#[cfg(test)]
mod tests {
    use lewis_interfaces::msg::{Distance, Header, InputRef};

    use super::*;

    #[test]
    fn the_header_time_moves_and_nothing_else() {
        let message = Distance {
            header: Header {
                provider: "laser".into(),
                seq: 7,
                publish_time_ns: 1_000,
                inputs: vec![InputRef {
                    channel: "/base/GroundTruth".into(),
                    seq: 3,
                }],
            },
            min_distance: 1.5,
            ..Distance::default()
        };
        let mut bytes = cdr::to_vec(&message);
        shift_header_time(&mut bytes, 500);
        let moved: Distance = cdr::from_bytes(&bytes).unwrap();
        assert_eq!(moved.header.publish_time_ns, 1_500);
        let mut back = moved.clone();
        back.header.publish_time_ns = 1_000;
        assert_eq!(back, message);
        let mut junk = b"junk".to_vec();
        shift_header_time(&mut junk, 500);
        assert_eq!(junk, b"junk");
    }
}
