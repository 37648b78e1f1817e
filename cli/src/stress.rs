//! `lewis stress-publish` (hidden): the recorder's load generator. Publishes the stress mix
//! (20 channels at 1 kHz of small messages and a 640x480 RGB stream at 30 Hz) into a
//! namespace and prints, as JSON, what it published and how punctually; with
//! `--print-robot`, prints the robot description of its providers for `lewis record
//! --robot`.

use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;
use std::time::Duration;

use anyhow::Context as _;
use clap::Args;
use lewis_recorder::live::load::publish_stress;
use lewis_recorder::stress::robot_toml;

use lewis_runtime::ipc::Namespace;

/// Arguments of `lewis stress-publish`.
#[derive(Debug, Args)]
pub struct StressArgs {
    /// The IPC namespace (default: `LEWIS_NAMESPACE`, else `default`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// How long the traffic lasts (`30s`).
    #[arg(long, value_name = "DURATION", default_value = "30s", value_parser = lewis_stdx::parse_duration)]
    pub duration: Duration,
    /// Write the report (JSON) here rather than on stdout.
    #[arg(long, value_name = "FILE")]
    pub report: Option<PathBuf>,
    /// Print the robot description of the mix's providers and exit.
    #[arg(long)]
    pub print_robot: bool,
}

/// Runs `lewis stress-publish`.
pub fn run(args: &StressArgs) -> anyhow::Result<ExitCode> {
    let mut out = std::io::stdout().lock();
    if args.print_robot {
        out.write_all(robot_toml().as_bytes())?;
        return Ok(ExitCode::SUCCESS);
    }
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let duration = args.duration;
    anyhow::ensure!(
        !duration.is_zero(),
        "--duration 0s: give a duration above 0"
    );
    let report = publish_stress(&namespace, duration)?;
    let json = serde_json::to_string_pretty(&report)?;
    match &args.report {
        Some(path) => std::fs::write(path, json + "\n")
            .with_context(|| format!("cannot write the report {}", path.display()))?,
        None => writeln!(out, "{json}")?,
    }
    Ok(ExitCode::SUCCESS)
}
