//! `lewis up ROBOT.toml`: the broker and the robot's services, until Ctrl-C or `--duration`
//! (or until the goal or the mission given ends): `lewis_launch`.

use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context as _;
use clap::Args;
use lewis_launch::{Launch, LaunchOptions, MissionPlan};
use lewis_recorder::companion::{CompanionOptions, ImageCodec};
use lewis_runtime::broker::live::UpOptions;
use lewis_runtime::ipc::Namespace;
use lewis_runtime::live::ClockSource;
use lewis_runtime::supervise::DEFAULT_STOP_GRACE;
use lewis_sequencer::session::load_mission;

use crate::seq::MissionArgs;

/// Arguments of `lewis up`.
#[derive(Debug, Args)]
pub struct UpArgs {
    /// The robot description (`robots/*.toml`).
    pub robot: PathBuf,
    /// The IPC namespace (default: `LEWIS_NAMESPACE`, else `default`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// Stop after this long, as `8s` or `500ms` (default: run until Ctrl-C or SIGTERM).
    #[arg(long, value_name = "DURATION", value_parser = lewis_stdx::parse_duration)]
    pub duration: Option<Duration>,
    /// Milliseconds a service has between SIGTERM and SIGKILL when it is stopped.
    #[arg(long, value_name = "MS")]
    pub stop_grace_ms: Option<u64>,
    /// The clock the services read: `wall` (the machine's) or `played` (the time of a
    /// recording played by `lewis play`, on /lewis/clock, like ROS 2's use_sim_time).
    #[arg(long, value_name = "CLOCK", default_value = "wall")]
    pub clock: ClockSource,
    /// Do not record (by default a recorder subscribes before the services start).
    #[arg(long)]
    pub no_record: bool,
    /// The recording (default: `logs/<robot>-<UTC time>.mcap`).
    #[arg(
        short = 'o',
        long = "output",
        value_name = "PATH",
        conflicts_with = "no_record"
    )]
    pub output: Option<PathBuf>,
    /// Record no ROS 2 companion channels (by default LaserScan, PointCloud2, Odometry, tf
    /// and markers are written beside the robot's own messages, for Foxglove).
    #[arg(long, conflicts_with = "no_record")]
    pub no_companions: bool,
    /// Also record each camera image as a CompressedImage companion (png unless jpeg is
    /// given).
    #[arg(long, value_name = "FORMAT", num_args = 0..=1, default_missing_value = "png", conflicts_with_all = ["no_record", "no_companions"])]
    pub companion_images: Option<crate::export::ImagesArg>,
    /// Drive to a goal, then stop (`--goal X,Y`).
    #[command(flatten)]
    pub goal: crate::goal::GoalArgs,
    /// Run this mission script once the broker is up; `lewis up` ends with the mission: exit
    /// 0 when it reaches `stop` other than through recovery, 1 when it fails.
    #[arg(long, value_name = "MISSION.seq")]
    pub script: Option<PathBuf>,
    /// How the supervisor is asked and where the records go.
    #[command(flatten)]
    pub how: MissionArgs,
}

/// Runs `lewis up`: exit 0 when the goal or the mission succeeded (or, without either,
/// when the robot ran until it was stopped), 1 when it did not.
pub fn run(args: &UpArgs) -> anyhow::Result<ExitCode> {
    let robot = lewis_services::load_robot(&args.robot)?;
    let mission = match &args.script {
        Some(script) => Some(MissionPlan {
            script: script.clone(),
            mission: load_mission(script)?,
            options: args.how.options(false),
        }),
        None => None,
    };
    let options = LaunchOptions {
        up: UpOptions {
            // Services get an absolute path: they may run in another directory.
            robot_path: std::path::absolute(&args.robot)
                .with_context(|| format!("cannot resolve {}", args.robot.display()))?,
            namespace: Namespace::from_arg(args.namespace.as_deref())?,
            lewis_exe: std::env::current_exe().context("cannot find the lewis executable")?,
            duration: args.duration,
            stop_grace: args
                .stop_grace_ms
                .map_or(DEFAULT_STOP_GRACE, Duration::from_millis),
            clock: args.clock,
        },
        record: (!args.no_record).then(|| args.output.clone()),
        companions: (!args.no_companions).then(|| CompanionOptions {
            images: args.companion_images.map(ImageCodec::from),
        }),
        goal: args.goal.plan(&robot)?,
        mission,
    };
    let report = Launch::new(robot, options)?.run()?;
    if let Some(outcome) = &report.mission {
        crate::seq::report(outcome);
    }
    Ok(if report.succeeded() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
