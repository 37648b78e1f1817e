//! `lewis record`: records a running robot into MCAP (also what `lewis up` starts).

use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context as _;
use clap::Args;
use lewis_recorder::companion::{CompanionOptions, ImageCodec};
use lewis_recorder::live::child::{Summary, default_output, ready_line};
use lewis_recorder::live::{LiveOptions, TopicFilter, record};
use lewis_recorder::{Compression, QueueOptions, RecorderOptions, RobotDescription};
use lewis_runtime::ipc::Namespace;

use crate::export::ImagesArg;

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
    /// Write no companion channels (by default ROS 2's LaserScan, PointCloud2, Odometry,
    /// tf and markers are written beside the robot's own messages, for Foxglove).
    #[arg(long)]
    pub no_companions: bool,
    /// Also write each camera image as a CompressedImage companion (png unless jpeg is
    /// given): a second copy of every frame, so off by default.
    #[arg(long, value_name = "FORMAT", num_args = 0..=1, default_missing_value = "png", conflicts_with = "no_companions")]
    pub companion_images: Option<ImagesArg>,
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
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    // The recorder runs no service: it needs the file's channels, not kinds it could build
    // (an imported robot's sources have `kind = "recorded"`, which no harness starts).
    let robot = args
        .robot
        .as_deref()
        .map(|path| lewis_robot::load(path, &lewis_interfaces::interface_names()))
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
    recorder.companions = (!args.no_companions).then(|| CompanionOptions {
        images: args.companion_images.map(ImageCodec::from),
    });
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
    let report = record(&options, |ready| say(&ready_line(ready)))?;
    say(Summary(&report).to_string().trim_end());
    Ok(ExitCode::SUCCESS)
}

/// A line on stdout, flushed at once: `lewis up` waits for the ready line.
fn say(line: &str) {
    let mut out = std::io::stdout().lock();
    let _ = writeln!(out, "{line}");
    let _ = out.flush();
}
