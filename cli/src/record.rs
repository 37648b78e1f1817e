//! `lewis record`: records a running robot into MCAP (also what `lewis up` starts).

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::mpsc::{RecvTimeoutError, sync_channel};
use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::Args;
use lewis_recorder::live::{LiveOptions, Ready, TopicFilter, record};
use lewis_recorder::{Compression, QueueOptions, RecorderOptions, RobotDescription};
use lewis_runtime::ipc::{NAMESPACE_ENV, Namespace};
use lewis_runtime::supervise::{ChildSpec, Stream, Supervisor, SupervisorEvent};

use crate::up::namespace;

/// The line `lewis record` writes on stdout once every channel is subscribed: nothing
/// published after it is missed. `lewis up` waits for it before starting the services.
pub(crate) const READY_LINE: &str = "recording";

/// Arguments of `lewis record`.
#[derive(Debug, Args)]
pub struct RecordArgs {
    /// The IPC namespace (default: `LEWIS_NAMESPACE`, else `default`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// The output file (default: `logs/<robot>-<UTC time>.mcap`); never overwritten.
    #[arg(short = 'o', long = "output", value_name = "PATH")]
    pub output: Option<PathBuf>,
    /// Record only the topics matching one of these globs (`*` within one level of the
    /// name, `**` across levels): `--topics '/laser/*' '/lewis/**'`.
    #[arg(long, num_args = 1.., value_name = "GLOB")]
    pub topics: Vec<String>,
    /// The robot description: its providers' channels, health and commands are recorded,
    /// and it is stored in the file. Without it, the namespace's broker is asked which
    /// robot it runs (at once, and until it answers).
    #[arg(long, value_name = "FILE")]
    pub robot: Option<PathBuf>,
    /// Chunk compression.
    #[arg(long, default_value = "zstd", value_name = "zstd|lz4|none")]
    pub compression: Compression,
    /// Start a new file when the current one reaches this many bytes.
    #[arg(long, value_name = "BYTES")]
    pub split_size: Option<u64>,
    /// Start a new file when the current one spans this long (`60s`, `10m`).
    #[arg(long, value_name = "DURATION", value_parser = lewis_stdx::parse_duration_ns)]
    pub split_duration: Option<i64>,
    /// Stop after this long, as `8s` or `500ms` (default: until Ctrl-C or SIGTERM).
    #[arg(long, value_name = "DURATION", value_parser = lewis_stdx::parse_duration)]
    pub duration: Option<Duration>,
    /// Test knob: the writer pauses this many microseconds after each message (a slow
    /// disk).
    #[arg(long, value_name = "US", hide = true)]
    pub test_write_delay_us: Option<u64>,
    /// Test knob: the queue in front of the writer holds this many messages at most.
    #[arg(long, value_name = "N", hide = true)]
    pub test_queue_messages: Option<usize>,
}

/// Runs `lewis record`.
pub fn run(args: &RecordArgs) -> anyhow::Result<ExitCode> {
    let namespace = namespace(args.namespace.as_deref())?;
    // The recorder runs no service: it needs the file's channels, not kinds it could build
    // (an imported robot's sources have `kind = "recorded"`, which no harness starts).
    let robot = args
        .robot
        .as_deref()
        .map(|path| lewis_runtime::robot::load(path, &lewis_interfaces::interface_names()))
        .transpose()?;
    // Without --robot the robot is not known yet: the default name says `recording`.
    let robot_name = robot.as_ref().map_or("recording", |r| r.name.as_str());
    let path = match &args.output {
        Some(path) => path.clone(),
        None => default_output(Path::new("logs"), robot_name)?,
    };
    let mut recorder = RecorderOptions::new(&path);
    recorder.compression = args.compression;
    recorder.split_size_bytes = args.split_size;
    anyhow::ensure!(
        args.split_duration != Some(0) && args.duration.is_none_or(|d| !d.is_zero()),
        "--split-duration and --duration must be longer than 0s"
    );
    recorder.split_duration_ns = args.split_duration;
    if let Some(file) = &args.robot {
        recorder.robot_description = Some(RobotDescription {
            file_name: file.file_name().map_or_else(
                || "robot.toml".to_owned(),
                |n| n.to_string_lossy().into_owned(),
            ),
            toml: std::fs::read_to_string(file)
                .with_context(|| format!("cannot read {}", file.display()))?,
        });
    }
    let options = LiveOptions {
        namespace,
        robot,
        topics: TopicFilter::new(args.topics.as_slice())?,
        recorder,
        queue: QueueOptions {
            write_delay: Duration::from_micros(args.test_write_delay_us.unwrap_or(0)),
            capacity_messages: args
                .test_queue_messages
                .unwrap_or(QueueOptions::default().capacity_messages),
            ..QueueOptions::default()
        },
        duration: args.duration,
    };
    let report = record(&options, announce_ready)?;
    let recording = &report.recording;
    let mut summary = format!(
        "recorded {} messages on {} topics into {} ({} lost, {} dropped by the recorder)\n",
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
    );
    if let Some(index) = &recording.index {
        let _ = writeln!(summary, "parts index: {}", index.display());
    }
    if let Some(peak) = peak_resident_kib() {
        let _ = writeln!(
            summary,
            "peak resident memory {:.1} MiB (VmHWM)",
            peak as f64 / 1024.0
        );
    }
    for (topic, counts) in &recording.counts {
        if counts.lost > 0 || counts.dropped > 0 {
            let _ = writeln!(
                summary,
                "  {topic}: {} written, {} lost, {} dropped",
                counts.written, counts.lost, counts.dropped
            );
        }
    }
    let mut out = std::io::stdout().lock();
    let _ = out.write_all(summary.as_bytes());
    Ok(ExitCode::SUCCESS)
}

/// Says on stdout that every channel is subscribed.
fn announce_ready(ready: &Ready) {
    let mut out = std::io::stdout().lock();
    let robot = ready
        .robot
        .as_deref()
        .map_or_else(|| "no robot yet".to_owned(), |r| format!("robot {r}"));
    let _ = writeln!(
        out,
        "{READY_LINE} {} topics to {} ({robot})",
        ready.topics.len(),
        ready.path.display()
    );
    let _ = out.flush();
}

/// The peak resident memory of this process (`VmHWM` of `/proc/self/status`), in KiB.
fn peak_resident_kib() -> Option<u64> {
    let status = std::fs::read_to_string("/proc/self/status").ok()?;
    status
        .lines()
        .find_map(|l| l.strip_prefix("VmHWM:"))?
        .split_whitespace()
        .next()?
        .parse()
        .ok()
}

/// `FOLDER/<robot>-<UTC time>.mcap`, creating the folder.
pub(crate) fn default_output(folder: &Path, robot: &str) -> anyhow::Result<PathBuf> {
    std::fs::create_dir_all(folder)
        .with_context(|| format!("cannot create the folder {}", folder.display()))?;
    let stamp = jiff::Timestamp::now().strftime("%Y%m%dT%H%M%SZ");
    Ok(folder.join(format!("{robot}-{stamp}.mcap")))
}

/// The name of the recorder among `lewis up`'s children.
const RECORDER_CHILD: &str = "recorder";

/// How long the recorder has to close its file after SIGTERM before SIGKILL (it writes
/// what is queued, at most the queue's bound, then the summary).
const RECORDER_STOP_GRACE: Duration = Duration::from_secs(20);

/// The longest `lewis up` waits for the recorder to subscribe before starting the robot
/// without it.
const RECORDER_READY_TIMEOUT: Duration = Duration::from_secs(30);

/// The recorder `lewis up` runs: a `lewis record` child process, supervised (it dies with
/// `lewis up`, even one killed with SIGKILL), started and subscribed before the services,
/// stopped after them.
pub(crate) struct RecorderChild {
    supervisor: Supervisor,
    path: PathBuf,
}

impl RecorderChild {
    /// Starts `lewis record` for `robot` and waits until it has subscribed to every channel.
    /// `Ok(None)` when it could not start recording (the reason is logged): the robot runs
    /// anyway.
    ///
    /// # Errors
    /// When the supervisor cannot be set up or the default output folder cannot be made.
    pub(crate) fn start(
        lewis_exe: &Path,
        robot_path: &Path,
        robot_name: &str,
        namespace: &Namespace,
        output: Option<&Path>,
    ) -> anyhow::Result<Option<Self>> {
        let path = match output {
            Some(path) => path.to_path_buf(),
            None => default_output(Path::new("logs"), robot_name)?,
        };
        let (lines_tx, lines) = sync_channel(64);
        let mut supervisor = Supervisor::with_log_sink(lines_tx)?;
        let spec = ChildSpec::new(RECORDER_CHILD, lewis_exe)
            .arg("record")
            .args(["--namespace", namespace.as_str(), "--robot"])
            .arg(robot_path)
            .arg("-o")
            .arg(&path)
            .env(NAMESPACE_ENV, namespace.as_str())
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
                    tracing::info!("recorder: {}", line.text);
                    // Later lines still go to the log; the sink is no longer read.
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

    /// Stops the recorder (SIGTERM: it writes what is queued and closes the file).
    pub(crate) fn stop(mut self) {
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
