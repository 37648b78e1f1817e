//! `lewis info`.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use lewis_replay::{InfoOptions, inspect};

/// `lewis info FILE.mcap`
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The recording.
    pub file: PathBuf,
    /// Print the report as JSON.
    #[arg(long)]
    pub json: bool,
    /// Also print the first N messages, decoded.
    #[arg(long, value_name = "N", default_value_t = 0)]
    pub messages: usize,
    /// Read every record instead of trusting the summary, and report where they disagree.
    #[arg(long)]
    pub scan: bool,
}

/// Prints the report; a damaged (truncated) file exits 1, after saying how to recover it.
pub fn run(args: &InfoArgs) -> anyhow::Result<ExitCode> {
    let options = InfoOptions {
        messages: args.messages,
        scan: args.scan,
    };
    let report = inspect(&args.file, &options)?;
    let mut out = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut out, &report)?;
        writeln!(out)?;
    } else {
        write!(out, "{report}")?;
    }
    Ok(if report.damage.is_some() {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
