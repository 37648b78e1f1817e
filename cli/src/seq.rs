//! `lewis seq ...`: mission scripts.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Subcommand;

/// `lewis seq ...`
#[derive(Debug, Subcommand)]
pub enum SeqCommand {
    /// Check a mission script: syntax, undefined or unreachable states, programs.
    Check {
        /// The script.
        script: PathBuf,
    },
}

pub fn run(command: SeqCommand) -> anyhow::Result<ExitCode> {
    let mut out = std::io::stdout().lock();
    match command {
        SeqCommand::Check { script } => match lewis_sequencer::check_file(&script) {
            Ok(checked) => {
                if checked.warnings.iter().next().is_some() {
                    writeln!(out, "{}", checked.warnings)?;
                }
                writeln!(out, "{}: ok", script.display())?;
                Ok(ExitCode::SUCCESS)
            }
            Err(diagnostics) => {
                writeln!(out, "{diagnostics}")?;
                Ok(ExitCode::FAILURE)
            }
        },
    }
}
