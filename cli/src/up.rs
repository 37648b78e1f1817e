//! `lewis up ROBOT.toml`: the broker and the robot's services, until Ctrl-C or `--duration`
//! (or until the goal or the mission given ends): `lewis_launch`.

use lewis_service::ServiceRegistry;
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
    /// For a robot on more than one host (`[[hosts]]`): the host this is. The first host
    /// (the default) runs the broker, the recorder and the mission; another runs its own
    /// services on the broker's orders.
    #[arg(long, value_name = "NAME")]
    pub host: Option<String>,
}

/// Runs `lewis up`: exit 0 when the goal or the mission succeeded (or, without either,
/// when the robot ran until it was stopped), 1 when it did not.
pub fn run(args: &UpArgs, registry: &ServiceRegistry) -> anyhow::Result<ExitCode> {
    let robot = registry.load_robot(&args.robot)?;
    let robot_host = robot.robot_host().map(|h| h.name.clone());
    match (&args.host, &robot_host) {
        (Some(host), None) => anyhow::bail!(
            "{} runs on one machine (it has no [[hosts]]): run it without --host {host}",
            args.robot.display()
        ),
        (Some(host), Some(first)) if host != first => return run_other_host(args, &robot, host),
        _ => {}
    }
    let mission = match &args.script {
        Some(script) => Some(MissionPlan {
            script: script.clone(),
            mission: load_mission(script)?,
            options: args.how.options(false),
        }),
        None => None,
    };
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let options = LaunchOptions {
        up: UpOptions {
            // Services get an absolute path: they may run in another directory.
            robot_path: std::path::absolute(&args.robot)
                .with_context(|| format!("cannot resolve {}", args.robot.display()))?,
            namespace: namespace.clone(),
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
    let report = match robot_host {
        #[cfg(feature = "hosts")]
        Some(host) => {
            let launch = Launch::new(robot.clone(), options)?;
            let _ = lewis_runtime::ipc::wipe_stale(&namespace);
            let scratch = scratch_dir(&namespace, &host)?;
            let mut hosts = lewis_bridge::RobotHost::start(&robot, &namespace, &scratch)?;
            tracing::info!("host {host} of robot {}: bridge up", robot.name);
            let report = launch.run_with_hosts(Some(&mut hosts))?;
            // The bridge kept the namespace in use when the run ended: wiped once it is down.
            drop(hosts);
            let _ = lewis_runtime::ipc::wipe_ended(&namespace);
            report
        }
        #[cfg(not(feature = "hosts"))]
        Some(_) => anyhow::bail!(without_hosts(&args.robot)),
        None => Launch::new(robot, options)?.run()?,
    };
    if let Some(outcome) = &report.mission {
        crate::seq::report(outcome);
    }
    Ok(if report.succeeded() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

/// Why a robot on more than one host cannot run with this binary.
#[cfg(not(feature = "hosts"))]
fn without_hosts(robot: &std::path::Path) -> String {
    format!(
        "{} has more than one host ([[hosts]]), and this lewis is built without the bridge \
         between hosts: build it with `--features hosts` (a default feature)",
        robot.display()
    )
}

/// Another host of a robot on more than one, in a binary without the bridge: an error.
#[cfg(not(feature = "hosts"))]
fn run_other_host(
    args: &UpArgs,
    _robot: &lewis_robot::Robot,
    _host: &str,
) -> anyhow::Result<ExitCode> {
    anyhow::bail!(without_hosts(&args.robot))
}

/// Another host of a robot on more than one: its services on the broker's orders, its
/// bridge, until Ctrl-C or SIGTERM.
#[cfg(feature = "hosts")]
fn run_other_host(
    args: &UpArgs,
    robot: &lewis_robot::Robot,
    host: &str,
) -> anyhow::Result<ExitCode> {
    if args.script.is_some() || args.goal.plan(robot)?.is_some() {
        anyhow::bail!(
            "a mission or a goal runs on the robot host ({}), not on {host}",
            robot.robot_host().map_or("", |h| h.name.as_str())
        );
    }
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let _ = lewis_runtime::ipc::wipe_stale(&namespace);
    let signals =
        lewis_runtime::live::StopSignals::install().context("cannot catch the stop signals")?;
    let options = lewis_bridge::HostOptions {
        host: host.to_owned(),
        robot_path: std::path::absolute(&args.robot)
            .with_context(|| format!("cannot resolve {}", args.robot.display()))?,
        namespace: namespace.clone(),
        lewis_exe: std::env::current_exe().context("cannot find the lewis executable")?,
        stop_grace: args
            .stop_grace_ms
            .map_or(DEFAULT_STOP_GRACE, Duration::from_millis),
        scratch: scratch_dir(&namespace, host)?,
    };
    lewis_bridge::run_host(robot, &options, &signals)?;
    Ok(ExitCode::SUCCESS)
}

/// A folder of this run's own, readable by its user only: the shared key's dictionary.
#[cfg(feature = "hosts")]
fn scratch_dir(namespace: &Namespace, host: &str) -> anyhow::Result<PathBuf> {
    use std::os::unix::fs::DirBuilderExt as _;
    let dir = std::env::temp_dir().join(format!("lewis-{}-{host}", namespace.as_str()));
    std::fs::DirBuilder::new()
        .recursive(true)
        .mode(0o700)
        .create(&dir)
        .with_context(|| format!("cannot create {}", dir.display()))?;
    Ok(dir)
}
