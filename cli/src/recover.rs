//! `lewis recover BROKEN.mcap -o FIXED.mcap`: repairs a recording whose writer died.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use clap::Args;
use lewis_recorder::recover;

/// Arguments of `lewis recover`.
#[derive(Debug, Args)]
pub struct RecoverArgs {
    /// The recording to repair (left unchanged).
    pub broken: PathBuf,
    /// Where to write the repaired recording.
    #[arg(short = 'o', long = "output", value_name = "FIXED.mcap")]
    pub output: PathBuf,
}

/// Runs `lewis recover`: writes everything up to the last complete chunk, with a summary.
pub fn run(args: &RecoverArgs) -> anyhow::Result<ExitCode> {
    let report = recover(&args.broken, &args.output)?;
    let mut text = String::new();
    if report.input_complete {
        let _ = writeln!(
            text,
            "{} was complete up to its summary: nothing lost, the summary was rebuilt",
            args.broken.display()
        );
    } else {
        let _ = writeln!(
            text,
            "{} was cut off: {} bytes kept, {} bytes of an incomplete chunk dropped{}",
            args.broken.display(),
            report.valid_bytes,
            report.discarded_bytes,
            report
                .damage
                .as_deref()
                .map(|d| format!(" ({d})"))
                .unwrap_or_default()
        );
    }
    let _ = writeln!(
        text,
        "wrote {}: {} messages in {} chunks, {} metadata records, {} attachments",
        args.output.display(),
        report.messages,
        report.chunks,
        report.metadata,
        report.attachments
    );
    for (topic, count) in &report.messages_per_topic {
        let _ = writeln!(text, "  {topic}: {count}");
    }
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
    Ok(ExitCode::SUCCESS)
}
