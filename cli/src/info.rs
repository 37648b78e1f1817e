//! `lewis info`.

use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;

/// `lewis info FILE.mcap`
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The recording.
    pub file: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Also print the first N messages, decoded.
    #[arg(long, value_name = "N")]
    pub messages: Option<usize>,
}

pub fn run(_args: &InfoArgs) -> anyhow::Result<ExitCode> {
    anyhow::bail!("lewis info is not wired yet")
}
