//! The live tap: records a running robot from its IPC channels (`lewis record`, and the
//! recorder that `lewis up` starts).
//!
//! Given a namespace and a robot description, it subscribes to every provider's data
//! channel of the robot file (all of them from the start: a provider that a failover starts
//! later is recorded from its first sample), every service's health and command log,
//! `/lewis/broker`, `/lewis/sequencer` and `/lewis/log` ([`robot_channels`]), keeps those
//! matching the `--topics` globs ([`TopicFilter`]), waits on all of them with the runtime's
//! [`WaitSet`]
//! (no polling), and offers each sample's bytes, unchanged, to the recorder's [`Tap`]
//! (`publish_time` and sequence number from the message header, `log_time` the receive
//! time). The tap never waits: the publishers' channels keep their own overflow policy
//! (the tap takes the deepest buffer they allow), and a full recorder queue drops and
//! counts.
//!
//! Without a robot description, it asks the namespace's broker which robot it runs
//! ([`discover`]): at once (a running robot is then recorded from the ready line on) and,
//! while no broker answers, again every half second, adding the robot's channels when it
//! does. The description is stored in the file either way.
//!
//! When the recording fails (a full disk, a read-only folder, a missing one), the file is
//! closed valid as far as the recorder can, the failure is published on `/lewis/broker`
//! (action [`RECORDER_FAILED`], the error as reason) so that it is recorded by nobody but
//! seen by everyone, and [`record`] returns the error, which names the path. The robot is
//! not touched.
//!
//! [`WaitSet`]: lewis_runtime::ipc::WaitSet
//! [`Tap`]: crate::Tap

pub mod child;
pub mod discover;
pub mod load;
mod plan;
mod tap;

pub use plan::{BadGlob, META_KIND, TapChannel, TopicFilter, robot_channels};
pub use tap::{Ended, Growth, TapCounts};

use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Broker, BrokerAction};
use lewis_robot::Robot;
use lewis_runtime::clock::LiveClock;
use lewis_runtime::ipc::{Ipc, IpcError, Namespace, WaitError};
use lewis_runtime::live::StopSignals;
use lewis_runtime::names;
use thiserror::Error;

use crate::error::RecordError;
use crate::options::RecorderOptions;
use crate::queue::{QueueOptions, spawn};
use crate::recorder::{Recorder, RecordingReport};
use discover::Discovery;
use tap::LiveTap;

/// The IPC node name of the recorder (shown in node lists).
pub const RECORDER_NODE: &str = "lewis-recorder";

/// The `action` of the [`Broker`] message the recorder publishes on `/lewis/broker` when it
/// stops on an error.
pub const RECORDER_FAILED: &str = BrokerAction::RecorderFailed.as_str();

/// Why a live recording could not run, or stopped.
#[derive(Debug, Error)]
pub enum LiveError {
    /// Writing failed; the error names the file.
    #[error(transparent)]
    Record(#[from] RecordError),
    /// A channel could not be opened.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// Waiting failed.
    #[error(transparent)]
    Wait(#[from] WaitError),
    /// The stop signals could not be caught.
    #[error("cannot catch SIGTERM and SIGINT: {0}")]
    Signals(std::io::Error),
    /// More channels than one wait can watch.
    #[error(
        "cannot tap {count} channels at once (at most {max}): narrow the recording with --topics"
    )]
    TooManyChannels {
        /// Channels selected.
        count: usize,
        /// The most one tap watches.
        max: usize,
    },
}

/// What to record and how.
#[derive(Debug, Clone)]
pub struct LiveOptions {
    /// The namespace of the running robot.
    pub namespace: Namespace,
    /// The robot description, whose providers, health and command channels are recorded;
    /// without one, the broker of the namespace is asked for it.
    pub robot: Option<Robot>,
    /// The topics to keep.
    pub topics: TopicFilter,
    /// The file(s) to write.
    pub recorder: RecorderOptions,
    /// The queue between the tap and the writer thread (and the slow-writer test knob).
    pub queue: QueueOptions,
    /// Stop after this long (`None`: until SIGTERM or SIGINT).
    pub duration: Option<Duration>,
}

/// What [`record`] tells its caller once every channel is subscribed (before any sample
/// is taken): from then on, nothing published on those channels is missed.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Ready {
    /// The topics subscribed, in order.
    pub topics: Vec<String>,
    /// The first file written.
    pub path: std::path::PathBuf,
    /// The robot recorded (given, or found from its broker); `None` while no broker has
    /// answered.
    pub robot: Option<String>,
}

/// What a live recording did.
#[derive(Debug, Clone)]
pub struct LiveReport {
    /// The files and the counts per topic.
    pub recording: RecordingReport,
    /// What the tap counted.
    pub tap: TapCounts,
    /// Why it ended.
    pub ended: Ended,
}

/// Records until SIGTERM, SIGINT or the duration; calls `on_ready` once subscribed.
///
/// # Errors
/// When IPC or the signal handlers cannot be set up, or when writing fails (then the failure
/// was also published on `/lewis/broker`).
pub fn record(
    options: &LiveOptions,
    on_ready: impl FnOnce(&Ready),
) -> Result<LiveReport, LiveError> {
    let signals = StopSignals::install().map_err(LiveError::Signals)?;
    let ipc = Ipc::open(&options.namespace, RECORDER_NODE)?;
    let announcer = Announcer { ipc: &ipc };
    let clock = LiveClock::new();
    let mut recorder_options = options.recorder.clone();
    let mut robot = options.robot.clone();
    let mut discovery = None;
    if robot.is_none() {
        let mut asking = Discovery::new(&ipc)?;
        match asking.ask_and_wait() {
            Some(found) => {
                tracing::info!(
                    "recording robot `{}`: its broker said which robot it runs",
                    found.robot.name
                );
                robot = Some(found.robot);
                recorder_options.robot_description = Some(found.description);
            }
            None => {
                tracing::warn!(
                    "no broker answers in namespace `{}`: recording /lewis/broker, /lewis/sequencer and /lewis/log, and the robot's channels once its broker answers (or give --robot)",
                    options.namespace
                );
                discovery = Some(asking);
            }
        }
    }
    let plan: Vec<TapChannel> = robot_channels(robot.as_ref())
        .into_iter()
        .filter(|c| options.topics.matches(c.topic()))
        .collect();
    let recorder = Recorder::create(recorder_options).map_err(|e| announcer.failed(&clock, e))?;
    let path = recorder.current_path().to_path_buf();
    let (tap, writer) = spawn(recorder, options.queue, move || clock.now_ns())
        .map_err(|e| announcer.failed(&clock, e))?;
    let mut live = match LiveTap::subscribe(&ipc, &plan, &tap, clock) {
        Ok(live) => live,
        Err(e) => {
            // The file holds nothing yet: close it valid, the error is the subscription's.
            let _ = writer.finish();
            return Err(e);
        }
    };
    if let Some(discovery) = discovery {
        live.grow_with(Growth {
            discovery,
            topics: options.topics.clone(),
        });
    }
    on_ready(&Ready {
        topics: plan.iter().map(|c| c.topic().to_owned()).collect(),
        path,
        robot: robot.map(|r| r.name),
    });
    let end = options.duration.map(|d| Instant::now() + d);
    let ended = live.run(&ipc, &tap, &writer, &signals, end);
    let recording = writer.finish().map_err(|e| announcer.failed(&clock, e))?;
    Ok(LiveReport {
        recording,
        tap: live.counts(),
        ended: ended?,
    })
}

/// How long the recorder stays after publishing its failure, so that subscribers take it.
const FAILURE_LINGER: Duration = Duration::from_millis(500);

/// Publishes the recorder's failure on `/lewis/broker`. The publisher is made only then:
/// the channel's few publisher places belong to the broker.
struct Announcer<'i> {
    ipc: &'i Ipc,
}

impl Announcer<'_> {
    /// Publishes `error` (once: a recorder fails once) and gives it back.
    fn failed(&self, clock: &LiveClock, error: RecordError) -> LiveError {
        let message = failure_message(&error, 1, clock.now_ns());
        let len = cdr::encoded_len(&message);
        let published = self
            .ipc
            .publisher(names::BROKER_CHANNEL, &names::broker_config())
            .map_err(|e| e.to_string())
            .and_then(|mut publisher| {
                let published = publisher
                    .publish_with(len, |buf| {
                        let _ = cdr::encode_into(&message, buf);
                    })
                    .map_err(|e| e.to_string())?;
                tracing::info!(
                    "recording failed: told /lewis/broker ({} subscribers)",
                    published.delivered_to
                );
                // There is no acknowledgement to wait for, and a sample not yet taken goes
                // with its publisher's process: give the subscribers time to take it.
                std::thread::sleep(FAILURE_LINGER);
                Ok(())
            });
        if let Err(e) = published {
            tracing::warn!("cannot tell /lewis/broker that recording failed: {e}");
        }
        LiveError::Record(error)
    }
}

/// The [`Broker`] message saying that the recorder stopped on `error`.
#[must_use]
pub fn failure_message(error: &RecordError, seq: u64, now_ns: i64) -> Broker {
    let mut message = Broker {
        action: RECORDER_FAILED.to_owned(),
        reason: error.to_string(),
        service: RECORDER_NODE.to_owned(),
        at_ns: now_ns,
        ..Broker::default()
    };
    message.header.provider = RECORDER_NODE.to_owned();
    message.header.seq = seq;
    message.header.publish_time_ns = now_ns;
    message
}

#[cfg(test)]
mod tests {
    use std::path::PathBuf;

    use super::*;

    #[test]
    fn a_failure_is_a_broker_message_naming_the_file() {
        let error = RecordError::DiskFull {
            path: PathBuf::from("/logs/run.mcap"),
            closed_valid: true,
        };
        let message = failure_message(&error, 1, 77);
        assert_eq!(
            (
                message.action.as_str(),
                message.service.as_str(),
                message.at_ns,
                message.header.seq,
                message.header.provider.as_str()
            ),
            (RECORDER_FAILED, RECORDER_NODE, 77, 1, RECORDER_NODE)
        );
        assert!(
            message
                .reason
                .starts_with("/logs/run.mcap: the disk is full"),
            "{}",
            message.reason
        );
    }
}
