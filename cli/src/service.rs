//! `lewis service NAME --robot FILE`: one service of a robot, in this process (what `lewis
//! up` starts for every service with a `kind`).

use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Args;
use lewis_runtime::ipc::Namespace;
use lewis_runtime::live::{CLOCK_ENV, ClockSource, run_service};
use lewis_runtime::service::ServiceRegistry;

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

/// Every service kind this binary can run.
#[must_use]
pub fn registry() -> ServiceRegistry {
    lewis_services::registry()
}

/// Runs `lewis service`.
pub fn run(args: &ServiceArgs) -> anyhow::Result<ExitCode> {
    let robot = lewis_services::load_robot(&args.robot)?;
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let clock = match args.clock {
        Some(clock) => clock,
        None => match std::env::var(CLOCK_ENV) {
            Ok(value) => value
                .parse()
                .with_context(|| format!("{CLOCK_ENV}={value}"))?,
            Err(_) => ClockSource::Wall,
        },
    };
    run_service(&robot, &args.name, &registry(), &namespace, clock)?;
    Ok(ExitCode::SUCCESS)
}
