//! The recorder as a child process of `lewis up`: a `lewis record` process, supervised (it
//! dies with its parent, even one killed with SIGKILL), started and subscribed before the
//! services, stopped after them. Also the words the two share: the ready line, the default
//! file name and the summary a recording ends with.

use std::fmt;
use std::path::{Path, PathBuf};
use std::sync::mpsc::{RecvTimeoutError, sync_channel};
use std::time::{Duration, Instant};

use lewis_runtime::ipc::{NAMESPACE_ENV, Namespace};
use lewis_runtime::supervise::{ChildSpec, Stream, SuperviseError, Supervisor, SupervisorEvent};

use super::{LiveReport, Ready};
use crate::companion::CompanionOptions;

/// The line `lewis record` writes on stdout once every channel is subscribed: nothing
/// published after it is missed. [`RecorderChild::start`] waits for it before the robot's
/// services start.
pub const READY_LINE: &str = "recording";

/// The name of the recorder among its parent's children.
const RECORDER_CHILD: &str = "recorder";

/// How long the recorder has to close its file after SIGTERM before SIGKILL (it writes
/// what is queued, at most the queue's bound, then the summary).
const RECORDER_STOP_GRACE: Duration = Duration::from_secs(20);

/// The longest the parent waits for the recorder to subscribe before starting the robot
/// without it.
const RECORDER_READY_TIMEOUT: Duration = Duration::from_secs(30);

/// The ready line for `ready`: [`READY_LINE`], then what is recorded where.
#[must_use]
pub fn ready_line(ready: &Ready) -> String {
    let robot = ready
        .robot
        .as_deref()
        .map_or_else(|| "no robot yet".to_owned(), |r| format!("robot {r}"));
    format!(
        "{READY_LINE} {} topics to {} ({robot})",
        ready.topics.len(),
        ready.path.display()
    )
}

/// `FOLDER/<robot>-<UTC time>.mcap`, creating the folder.
///
/// # Errors
/// When the folder cannot be made.
pub fn default_output(folder: &Path, robot: &str) -> std::io::Result<PathBuf> {
    std::fs::create_dir_all(folder).map_err(|e| {
        std::io::Error::new(
            e.kind(),
            format!("cannot create the folder {}: {e}", folder.display()),
        )
    })?;
    let stamp = jiff::Timestamp::now().strftime("%Y%m%dT%H%M%SZ");
    Ok(folder.join(format!("{robot}-{stamp}.mcap")))
}

/// What a recording ends with, for people: messages, topics, files, losses, and the topics
/// that lost some.
#[derive(Debug, Clone, Copy)]
pub struct Summary<'a>(pub &'a LiveReport);

impl fmt::Display for Summary<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let recording = &self.0.recording;
        writeln!(
            f,
            "recorded {} messages on {} topics into {} ({} lost, {} dropped by the recorder)",
            recording.messages(),
            recording.counts.len(),
            recording
                .parts
                .iter()
                .map(|p| p.display().to_string())
                .collect::<Vec<_>>()
                .join(", "),
            recording.lost(),
            recording.counts.values().map(|c| c.dropped).sum::<u64>(),
        )?;
        if let Some(index) = &recording.index {
            writeln!(f, "parts index: {}", index.display())?;
        }
        if let Some(peak) = lewis_stdx::peak_resident_kib() {
            writeln!(
                f,
                "peak resident memory {:.1} MiB (VmHWM)",
                peak as f64 / 1024.0
            )?;
        }
        for (topic, counts) in &recording.counts {
            if counts.lost > 0 || counts.dropped > 0 {
                writeln!(
                    f,
                    "  {topic}: {} written, {} lost, {} dropped",
                    counts.written, counts.lost, counts.dropped
                )?;
            }
        }
        Ok(())
    }
}

/// Where [`RecorderChild::start`] records, and with which program.
#[derive(Debug, Clone)]
pub struct ChildOptions {
    /// The `lewis` executable (its `record` subcommand is the recorder).
    pub lewis_exe: PathBuf,
    /// The robot file, stored in the recording.
    pub robot_path: PathBuf,
    /// The robot's name, for the default file name.
    pub robot_name: String,
    /// The namespace recorded.
    pub namespace: Namespace,
    /// The file (default: `logs/<robot>-<UTC time>.mcap`).
    pub output: Option<PathBuf>,
    /// The ROS 2 companion channels to write (`None`: none).
    pub companions: Option<CompanionOptions>,
}

/// A recorder running as a child process.
pub struct RecorderChild {
    supervisor: Supervisor,
    path: PathBuf,
}

impl fmt::Debug for RecorderChild {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("RecorderChild")
            .field("path", &self.path)
            .finish_non_exhaustive()
    }
}

/// Why the recorder child could not be set up.
#[derive(Debug, thiserror::Error)]
pub enum ChildError {
    /// Process supervision failed.
    #[error(transparent)]
    Supervise(#[from] SuperviseError),
    /// The default output folder could not be made.
    #[error(transparent)]
    Folder(#[from] std::io::Error),
}

impl RecorderChild {
    /// Starts `lewis record` and waits until it has subscribed to every channel. `Ok(None)`
    /// when it could not start recording (the reason is logged): the robot runs anyway.
    ///
    /// # Errors
    /// When the supervisor cannot be set up or the default output folder cannot be made.
    pub fn start(options: &ChildOptions) -> Result<Option<Self>, ChildError> {
        let path = match &options.output {
            Some(path) => path.clone(),
            None => default_output(Path::new("logs"), &options.robot_name)?,
        };
        let (lines_tx, lines) = sync_channel(64);
        let mut supervisor = Supervisor::with_log_sink(lines_tx)?;
        let mut spec = ChildSpec::new(RECORDER_CHILD, &options.lewis_exe)
            .arg("record")
            .args(["--namespace", options.namespace.as_str(), "--robot"])
            .arg(&options.robot_path)
            .arg("-o")
            .arg(&path);
        spec = match options.companions {
            None => spec.arg("--no-companions"),
            Some(CompanionOptions { images: None }) => spec,
            Some(CompanionOptions {
                images: Some(codec),
            }) => spec.args(["--companion-images", codec.name()]),
        };
        let spec = spec
            .env(NAMESPACE_ENV, options.namespace.as_str())
            .stop_grace(RECORDER_STOP_GRACE);
        if let Err(e) = supervisor.start(spec) {
            tracing::error!("cannot start the recorder: {e}; the robot runs without recording");
            return Ok(None);
        }
        let deadline = Instant::now() + RECORDER_READY_TIMEOUT;
        // The recorder's exit is seen by the supervisor, its ready line through the log sink:
        // two things to wait on, so the channel is read in short slices.
        loop {
            match lines.recv_timeout(Duration::from_millis(50)) {
                Ok(line) if line.stream == Stream::Stdout && line.text.starts_with(READY_LINE) => {
                    // The supervisor has logged the line already, as every line of the
                    // child's; the sink is no longer read.
                    drop(lines);
                    return Ok(Some(Self { supervisor, path }));
                }
                Ok(_) | Err(RecvTimeoutError::Timeout) => {}
                Err(RecvTimeoutError::Disconnected) => break,
            }
            if let Some(SupervisorEvent::Exited { status, .. }) = supervisor.try_event()? {
                tracing::error!(
                    "the recorder stopped before recording ({status}): see its error above; the robot runs without recording"
                );
                return Ok(None);
            }
            if Instant::now() >= deadline {
                break;
            }
        }
        tracing::error!(
            "the recorder did not subscribe within {RECORDER_READY_TIMEOUT:?}; the robot runs without recording"
        );
        let _ = supervisor.stop(RECORDER_CHILD);
        Ok(None)
    }

    /// The file being recorded (the first part when the recording is split).
    #[must_use]
    pub fn path(&self) -> &Path {
        &self.path
    }

    /// Stops the recorder (SIGTERM: it writes what is queued and closes the file).
    pub fn stop(mut self) {
        match self.supervisor.stop(RECORDER_CHILD) {
            Ok(Some(status)) if status.success() => {
                tracing::info!("recording closed: {}", self.path.display());
            }
            Ok(Some(status)) => tracing::warn!(
                "the recorder ended with {status}: {} may need `lewis recover`",
                self.path.display()
            ),
            Ok(None) => {}
            Err(e) => tracing::warn!("cannot stop the recorder: {e}"),
        }
    }
}
