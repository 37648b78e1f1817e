//! `lewis play`: a recording published into live IPC, like `ros2 bag play`, so that live
//! services, `lewis record` and the viewer consume it as if the robot were running.
//!
//! - **Channels**: every recorded topic (or those matching `--topics` globs) is published on
//!   the IPC channel of the same name in the namespace, with the settings the runtime gives
//!   that name ([`names::channel_config`]), so live subscribers open it unchanged. The CDR
//!   bytes are published exactly as recorded. Foreign ROS 2 recordings play too: their
//!   topics become channels of their names. Not played: the recorder's own stats
//!   (`/lewis/recorder/stats`, about the file, not the robot) and a recorded `/lewis/clock`
//!   (the player publishes its own).
//! - **Pace**: each message at its recorded log time, scaled by the rate ([`pace::Pacer`]),
//!   from `--start` on; `--loop` starts again at the end. Waiting is on the runtime's
//!   [`WaitSet`] with the stop signals and the keyboard, never a busy loop.
//! - **Control** ([`Controls`]): pause and resume, step one message while paused, quit; the
//!   command line gives the terminal's keys (space, `s`, `q`).
//! - **Clock**: the playback time is published on `/lewis/clock` ([`Clock`]) every 10 ms of
//!   wall time while playing, before a message when the last one is older, and at once on
//!   pause, step, resume, loop and end (the last one paused: the time stands at the end);
//!   its last value is kept for late joiners. Live services started with `--clock played`
//!   (`lewis up --clock played`) read it as their time and tick on it, unchanged
//!   (`lewis_runtime::live::service_clock`).
//!
//! At the end the channels stay open for [`LINGER`], so that subscribers take the last
//! messages. Playback is live: it reads the wall clock (`Instant`), unlike replay, which is
//! deterministic.

pub mod pace;

use std::collections::BTreeMap;
use std::os::fd::{AsFd, BorrowedFd};
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Clock, Header};
use lewis_recorder::live::{BadGlob, TopicFilter};
use lewis_runtime::ipc::{FdSource, Ipc, IpcError, Publisher, WaitError, WaitSet, WakeMode, Woken};
use lewis_runtime::live::StopSignals;
use lewis_runtime::names;

use crate::{RecordedMessage, RecordingError, RecordingFiles};
use pace::Pacer;

/// The clock is published at least this often while playing.
pub const CLOCK_PERIOD: Duration = Duration::from_millis(10);

/// How long the channels stay open after the last message: iceoryx2 drops the unread
/// samples of a publisher that is gone before a subscriber took them (a subscriber connects
/// when it next looks, which a woken subscriber does at once, a busy one a little later).
pub const LINGER: Duration = Duration::from_secs(1);

/// The provider name in the header of the clock messages.
pub const PLAYER_NAME: &str = "lewis-play";

/// How to play.
#[derive(Debug, Clone, PartialEq)]
pub struct PlayOptions {
    /// The recording's files (parts indexes expanded).
    pub inputs: Vec<PathBuf>,
    /// Recorded seconds per wall second.
    pub rate: f64,
    /// Start again at the end, until stopped.
    pub looping: bool,
    /// Play only the topics matching one of these globs (all when empty).
    pub topics: Vec<String>,
    /// Start this many seconds after the recording's start.
    pub start_s: f64,
    /// Start paused.
    pub paused: bool,
    /// Publish the playback time on `/lewis/clock`.
    pub clock: bool,
}

impl PlayOptions {
    /// Plays `inputs` once, at the recorded pace, every topic, with the clock.
    #[must_use]
    pub fn new(inputs: Vec<PathBuf>) -> Self {
        Self {
            inputs,
            rate: 1.0,
            looping: false,
            topics: Vec::new(),
            start_s: 0.0,
            paused: false,
            clock: true,
        }
    }
}

/// What a user asks of a playback.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PlayCommand {
    /// Pause, or resume when paused.
    TogglePause,
    /// Publish the next message (pausing first when playing).
    Step,
    /// Stop.
    Quit,
}

/// Where commands come from (the terminal's keys, or nothing).
pub trait Controls {
    /// A file descriptor that becomes readable when commands may be there.
    fn fd(&self) -> Option<BorrowedFd<'_>>;
    /// The commands available now, without waiting.
    fn take(&mut self) -> Vec<PlayCommand>;
}

/// No controls: the playback runs to its end or a stop signal.
#[derive(Debug, Clone, Copy, Default)]
pub struct NoControls;

impl Controls for NoControls {
    fn fd(&self) -> Option<BorrowedFd<'_>> {
        None
    }

    fn take(&mut self) -> Vec<PlayCommand> {
        Vec::new()
    }
}

/// Where the playback is, for a status line.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Status {
    /// The playback time, from the recording's start.
    pub time_ns: i64,
    /// The recording's length.
    pub total_ns: i64,
    /// Whether it is paused.
    pub paused: bool,
    /// Messages published so far.
    pub published: u64,
    /// Passes started (more than one with `--loop`).
    pub pass: u64,
}

/// What one topic's playback did.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct TopicCount {
    /// Messages published.
    pub published: u64,
    /// Messages the channel refused (too large, no shared memory).
    pub failed: u64,
}

/// What a playback did.
#[derive(Debug, Clone, PartialEq)]
pub struct PlayReport {
    /// The files played.
    pub files: Vec<PathBuf>,
    /// Per topic, what was published.
    pub topics: BTreeMap<String, TopicCount>,
    /// Passes over the recording.
    pub passes: u64,
    /// The first refusal of each topic that had one.
    pub first_failures: BTreeMap<String, String>,
    /// Whether it was stopped (signal or quit) before its end.
    pub stopped: bool,
    /// Clock messages published.
    pub clock_messages: u64,
}

/// Why a playback could not run.
#[derive(Debug, thiserror::Error)]
pub enum PlayError {
    /// The recording cannot be read.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// A channel cannot be opened (a live process opened it with other settings).
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// Waiting failed.
    #[error(transparent)]
    Wait(#[from] WaitError),
    /// A `--topics` glob does not parse.
    #[error(transparent)]
    Glob(#[from] BadGlob),
    /// An option does not fit the recording.
    #[error("{0}")]
    Option(String),
}

/// Plays a recording into `ipc`'s namespace until its end (or forever with `--loop`), a
/// stop signal or a quit command; `status` is told where it is at every clock tick and
/// state change.
///
/// # Errors
/// When the recording cannot be read, an option does not fit it, or a channel cannot be
/// opened.
pub fn play(
    options: &PlayOptions,
    ipc: &Ipc,
    stop: &StopSignals,
    controls: &mut dyn Controls,
    status: &mut dyn FnMut(&Status),
) -> Result<PlayReport, PlayError> {
    if !(options.rate.is_finite() && options.rate > 0.0) {
        return Err(PlayError::Option(format!(
            "--rate {}: give a positive rate (0.5 is half speed, 10 ten times faster)",
            options.rate
        )));
    }
    let files = RecordingFiles::open(&options.inputs)?;
    let (start_ns, end_ns) = (files.start_ns(), files.end_ns());
    let total_ns = end_ns - start_ns;
    // for the message only
    let total_s = total_ns as f64 / 1e9;
    if !(options.start_s.is_finite() && (0.0..=total_s).contains(&options.start_s)) {
        return Err(PlayError::Option(format!(
            "--start {}: the recording lasts {total_s:.3} s; give a time from 0 to that",
            options.start_s
        )));
    }
    let filter = TopicFilter::new(&options.topics)?;
    let selected: Vec<Arc<str>> = files
        .topics()
        .keys()
        .filter(|t| filter.matches(t))
        .filter(|t| &***t != lewis_recorder::STATS_TOPIC)
        .filter(|t| !(options.clock && &***t == names::CLOCK_CHANNEL))
        .cloned()
        .collect();
    if selected.is_empty() {
        let all: Vec<&str> = files.topics().keys().map(|t| &**t).collect();
        return Err(PlayError::Option(format!(
            "no topic of the recording matches --topics {}; it has: {}",
            options.topics.join(" "),
            all.join(", ")
        )));
    }
    // Bounded by the check above: within the recording.
    let from_ns = start_ns.saturating_add((options.start_s * 1e9) as i64);
    let source = files
        .paths()
        .next()
        .map(|p| p.display().to_string())
        .unwrap_or_default();
    let clock = if options.clock {
        Some(ipc.publisher(names::CLOCK_CHANNEL, &names::clock_config())?)
    } else {
        None
    };
    let mut player = Player {
        ipc,
        stop,
        controls,
        status,
        publishers: BTreeMap::new(),
        clock,
        clock_seq: 0,
        last_clock: None,
        ended: false,
        source,
        pacer: Pacer::new(options.rate, Instant::now(), from_ns, options.paused),
        step_pending: false,
        quit: false,
        start_ns,
        total_ns,
        published: 0,
        pass: 1,
        report: PlayReport {
            files: files.paths().map(std::path::Path::to_path_buf).collect(),
            topics: BTreeMap::new(),
            passes: 0,
            first_failures: BTreeMap::new(),
            stopped: false,
            clock_messages: 0,
        },
    };
    let topics: Vec<&str> = selected.iter().map(|t| &**t).collect();
    player.publish_clock(from_ns);
    loop {
        player.report.passes += 1;
        for message in files.messages_on(&topics)? {
            let message = message?;
            if message.log_time_ns < from_ns {
                continue;
            }
            if !player.wait_for(message.log_time_ns)? {
                player.report.stopped = true;
                return Ok(player.finish());
            }
            player.publish(&message)?;
        }
        if !options.looping {
            break;
        }
        player.pass += 1;
        player.pacer.restart(Instant::now(), from_ns);
        player.publish_clock(from_ns);
    }
    player.ended = true;
    player.publish_clock(end_ns);
    // Stopped by a signal meanwhile: the channels close at once.
    let _ = player.wait(Some(Instant::now() + LINGER))?;
    Ok(player.finish())
}

struct Player<'a> {
    ipc: &'a Ipc,
    stop: &'a StopSignals,
    controls: &'a mut dyn Controls,
    status: &'a mut dyn FnMut(&Status),
    publishers: BTreeMap<Arc<str>, Publisher>,
    clock: Option<Publisher>,
    clock_seq: u64,
    last_clock: Option<Instant>,
    /// The playback has ended: the last clock sample says paused, so that services on the
    /// played clock stop there instead of running on.
    ended: bool,
    source: String,
    pacer: Pacer,
    step_pending: bool,
    quit: bool,
    start_ns: i64,
    total_ns: i64,
    published: u64,
    pass: u64,
    report: PlayReport,
}

impl Player<'_> {
    /// Waits until the message at `log_ns` is due (or stepped to); `false` to stop.
    fn wait_for(&mut self, log_ns: i64) -> Result<bool, PlayError> {
        loop {
            if self.quit {
                return Ok(false);
            }
            let now = Instant::now();
            let deadline = if self.pacer.is_paused() {
                if self.step_pending {
                    self.step_pending = false;
                    self.pacer.stepped(log_ns);
                    self.publish_clock(log_ns);
                    return Ok(true);
                }
                None
            } else {
                let due = self.pacer.due(log_ns).unwrap_or(now);
                let clock_due = self.clock_due(now);
                if now >= due {
                    if clock_due.is_some_and(|t| t <= now) {
                        self.publish_clock(log_ns);
                    }
                    return Ok(true);
                }
                if clock_due.is_some_and(|t| t <= now) {
                    self.publish_clock(self.pacer.log_time_at(now));
                    continue;
                }
                Some(clock_due.map_or(due, |c| c.min(due)))
            };
            if !self.wait(deadline)? {
                return Ok(false);
            }
        }
    }

    /// When the next periodic clock message is due (`None` without a clock).
    fn clock_due(&self, now: Instant) -> Option<Instant> {
        self.clock.as_ref()?;
        Some(self.last_clock.map_or(now, |t| t + CLOCK_PERIOD))
    }

    /// Waits for a stop signal, a command or the deadline; `false` on a stop signal.
    fn wait(&mut self, deadline: Option<Instant>) -> Result<bool, PlayError> {
        let stop = FdSource::new(self.stop.as_fd());
        let keys = self.controls.fd().map(FdSource::new);
        let mut sources: Vec<&dyn lewis_runtime::ipc::Waitable> = vec![&stop];
        if let Some(keys) = &keys {
            sources.push(keys);
        }
        let woken = WaitSet::new(WakeMode::Event).wait(&sources, deadline)?;
        drop(sources);
        if self.stop.take() {
            return Ok(false);
        }
        if let Woken::Ready(fired) = woken
            && fired.contains(1)
        {
            for command in self.controls.take() {
                self.command(command);
            }
        }
        Ok(true)
    }

    fn command(&mut self, command: PlayCommand) {
        let now = Instant::now();
        match command {
            PlayCommand::TogglePause if self.pacer.is_paused() => self.pacer.resume(now),
            PlayCommand::TogglePause => self.pacer.pause(now),
            PlayCommand::Step => {
                self.pacer.pause(now);
                self.step_pending = true;
            }
            PlayCommand::Quit => self.quit = true,
        }
        let time = self.pacer.log_time_at(now);
        self.publish_clock(time);
    }

    fn publish(&mut self, message: &RecordedMessage) -> Result<(), PlayError> {
        let publisher = match self.publishers.get_mut(&message.topic) {
            Some(p) => p,
            None => {
                let config = names::channel_config(&message.topic);
                let p = self.ipc.publisher(&message.topic, &config)?;
                self.publishers.entry(message.topic.clone()).or_insert(p)
            }
        };
        let count = self
            .report
            .topics
            .entry(message.topic.to_string())
            .or_default();
        match publisher.publish(&message.data) {
            Ok(_) => {
                count.published += 1;
                self.published += 1;
            }
            Err(e) => {
                count.failed += 1;
                self.report
                    .first_failures
                    .entry(message.topic.to_string())
                    .or_insert_with(|| e.to_string());
            }
        }
        Ok(())
    }

    fn publish_clock(&mut self, time_ns: i64) {
        let now = Instant::now();
        self.last_clock = Some(now);
        let status = Status {
            time_ns: time_ns - self.start_ns,
            total_ns: self.total_ns,
            paused: self.pacer.is_paused(),
            published: self.published,
            pass: self.pass,
        };
        (self.status)(&status);
        let Some(publisher) = &mut self.clock else {
            return;
        };
        self.clock_seq += 1;
        let message = Clock {
            header: Header {
                provider: PLAYER_NAME.to_owned(),
                seq: self.clock_seq,
                publish_time_ns: time_ns,
                inputs: Vec::new(),
            },
            time_ns,
            rate: self.pacer.rate(),
            paused: self.ended || self.pacer.is_paused(),
            source: self.source.clone(),
        };
        // The clock is advisory: a refused sample is replaced by the next one.
        if publisher.publish(&cdr::to_vec(&message)).is_ok() {
            self.report.clock_messages += 1;
        }
    }

    fn finish(self) -> PlayReport {
        self.report
    }
}
