//! `lewis service NAME --robot FILE`: one service of a robot, in this process (what `lewis
//! up` starts for every service with a `kind`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Args;
use lewis_runtime::ipc::Namespace;
use lewis_runtime::live::{CLOCK_ENV, ClockSource, run_service};
use lewis_service::ServiceRegistry;

/// Arguments of `lewis service`.
#[derive(Debug, Args)]
pub struct ServiceArgs {
    /// The service's name in the robot file.
    pub name: String,
    /// The robot description.
    #[arg(long)]
    pub robot: PathBuf,
    /// The IPC namespace (default: `LEWIS_NAMESPACE`, else `default`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// The clock the service reads: `wall` or `played` (/lewis/clock from `lewis play`)
    /// (default: `LEWIS_CLOCK`, else `wall`).
    #[arg(long, value_name = "CLOCK")]
    pub clock: Option<ClockSource>,
}

/// The clock a service or a program reads: `--clock` when given, else `LEWIS_CLOCK` (what
/// `lewis up --clock` passes down), else the machine's.
///
/// # Errors
/// When `LEWIS_CLOCK` names no clock.
pub fn clock_source(arg: Option<ClockSource>) -> anyhow::Result<ClockSource> {
    Ok(match arg {
        Some(clock) => clock,
        None => match std::env::var(CLOCK_ENV) {
            Ok(value) => value
                .parse()
                .with_context(|| format!("{CLOCK_ENV}={value}"))?,
            Err(_) => ClockSource::Wall,
        },
    })
}

/// Runs `lewis service`.
pub fn run(args: &ServiceArgs, registry: &ServiceRegistry) -> anyhow::Result<ExitCode> {
    let robot = registry.load_robot(&args.robot)?;
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let clock = clock_source(args.clock)?;
    run_service(&robot, &args.name, registry, &namespace, clock)?;
    Ok(ExitCode::SUCCESS)
}
