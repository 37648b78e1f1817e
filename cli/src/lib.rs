//! The `lewis` command line: clap definitions and the dispatch to the library crates.

use std::process::ExitCode;

use clap::Parser;

/// The `lewis` command line.
#[derive(Debug, Parser)]
#[command(
    name = "lewis",
    version,
    about = "Fault-tolerant robot control, recorded and replayed"
)]
pub struct Cli {}

/// Runs the parsed command and returns the process exit code.
pub fn run(_cli: Cli) -> anyhow::Result<ExitCode> {
    Ok(ExitCode::SUCCESS)
}
