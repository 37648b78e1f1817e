//! `lewis info`.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use lewis_recording::{InfoOptions, inspect};

/// `lewis info FILE.mcap`
#[derive(Debug, Args)]
pub struct InfoArgs {
    /// The recording (a rotated recording's parts index, `RUN.parts.json`, describes each
    /// of its parts in turn).
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
/// With a parts index, one report per part (a JSON array with `--json`).
pub fn run(args: &InfoArgs) -> anyhow::Result<ExitCode> {
    let options = InfoOptions {
        messages: args.messages,
        scan: args.scan,
    };
    let index = args.file.extension().is_some_and(|e| e == "json");
    let files = lewis_recording::expand_inputs(std::slice::from_ref(&args.file))?;
    let mut reports = Vec::new();
    for file in &files {
        reports.push(inspect(file, &options)?);
    }
    let mut out = std::io::stdout().lock();
    if args.json && index {
        serde_json::to_writer_pretty(&mut out, &reports)?;
        writeln!(out)?;
    } else {
        for (i, report) in reports.iter().enumerate() {
            if args.json {
                serde_json::to_writer_pretty(&mut out, report)?;
                writeln!(out)?;
            } else {
                if index {
                    let separator = if i == 0 { "" } else { "\n" };
                    writeln!(
                        out,
                        "{separator}part {} of {} ({}):",
                        i + 1,
                        reports.len(),
                        args.file.display()
                    )?;
                }
                write!(out, "{report}")?;
            }
        }
    }
    Ok(if reports.iter().any(|r| r.damage.is_some()) {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}
