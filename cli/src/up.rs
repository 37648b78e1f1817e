//! `lewis up ROBOT.toml`: the broker and the robot's services, until Ctrl-C or `--duration`.

use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context as _;
use clap::Args;
use lewis_runtime::broker::live::{UpOptions, run_up};
use lewis_runtime::ipc::Namespace;
use lewis_runtime::live::ClockSource;
use lewis_runtime::robot::Robot;
use lewis_runtime::supervise::DEFAULT_STOP_GRACE;

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
    /// Drive to a goal, then stop (`--goal X,Y`).
    #[command(flatten)]
    pub goal: crate::goal::GoalArgs,
    /// Run a mission script with the robot, then stop (`--script MISSION.seq`).
    #[command(flatten)]
    pub mission: crate::mission::ScriptArgs,
}

/// Runs `lewis up`.
pub fn run(args: &UpArgs) -> anyhow::Result<ExitCode> {
    let robot = load_robot(&args.robot)?;
    let namespace = namespace(args.namespace.as_deref())?;
    let duration = args.duration;
    let options = UpOptions {
        // Services get an absolute path: they may run in another directory.
        robot_path: std::path::absolute(&args.robot)
            .with_context(|| format!("cannot resolve {}", args.robot.display()))?,
        namespace,
        lewis_exe: std::env::current_exe().context("cannot find the lewis executable")?,
        duration,
        stop_grace: args
            .stop_grace_ms
            .map_or(DEFAULT_STOP_GRACE, Duration::from_millis),
        clock: args.clock,
    };
    let recorder = if args.no_record {
        None
    } else {
        crate::record::RecorderChild::start(
            &options.lewis_exe,
            &options.robot_path,
            &robot.name,
            &options.namespace,
            args.output.as_deref(),
        )?
    };
    let goal = crate::goal::start(&args.goal, &robot, &options.namespace)?;
    let mission = crate::mission::start(&args.mission, &options.namespace)?;
    let (mut mission, mut recorder) = (mission, recorder);
    let mut mission_code = None;
    let mut finish = || {
        // The mission ends before the recorder stops, which records its last decisions.
        if let Some(run) = mission.take() {
            mission_code = Some(run.finish());
        }
        // Stopped after the services (it records their last words and the broker's stop
        // decisions) and before the broker's channels close.
        if let Some(recorder) = recorder.take() {
            recorder.stop();
        }
    };
    let summary = run_up(&robot, &options, &mut finish);
    // When the broker could not run, `finish` has not run yet.
    finish();
    let summary = summary?;
    tracing::info!(
        "broker down ({}), {} decisions",
        summary.ended_by,
        summary.decisions
    );
    if let Some(code) = mission_code {
        return code;
    }
    goal.map_or(Ok(ExitCode::SUCCESS), crate::goal::GoalRun::finish)
}

/// The namespace from `--namespace`, else `LEWIS_NAMESPACE`, else `default`.
pub(crate) fn namespace(given: Option<&str>) -> anyhow::Result<Namespace> {
    Ok(match given {
        Some(name) => Namespace::new(name)?,
        None => Namespace::from_env()?,
    })
}

/// Loads a robot description, checked whole: interfaces, kinds and their parameters.
pub(crate) fn load_robot(path: &Path) -> anyhow::Result<Robot> {
    Ok(lewis_services::load_robot(path)?)
}
