//! `lewis service NAME --robot FILE`: one service of a robot, in this process (what `lewis
//! up` starts for every service with a `kind`).

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use lewis_runtime::live::run_service;
use lewis_runtime::service::ServiceRegistry;

use crate::up::{init_logs, load_robot, namespace};

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
}

/// Every service kind this binary can run.
#[must_use]
pub fn registry() -> ServiceRegistry {
    lewis_services::registry()
}

/// Runs `lewis service`.
pub fn run(args: &ServiceArgs) -> anyhow::Result<ExitCode> {
    init_logs();
    let robot = load_robot(&args.robot)?;
    let namespace = namespace(args.namespace.as_deref())?;
    run_service(&robot, &args.name, &registry(), &namespace)?;
    Ok(ExitCode::SUCCESS)
}
