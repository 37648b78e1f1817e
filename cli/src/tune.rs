//! `lewis tune`: offline tuning of colour classes on recorded or saved images. The work is
//! `lewis-tune`'s; this parses, calls and prints what it returns.

use std::io::Write as _;
use std::process::ExitCode;

use clap::Subcommand;
use lewis_tune::{BlobfinderArgs, CheckArgs, FitArgs, LabelSimArgs, OpenArgs, PickArgs};

/// `lewis tune ...`
#[derive(Debug, Subcommand)]
pub enum TuneCommand {
    /// Re-run the blob finder (and the sign detector) with a colour file over recorded or
    /// saved images.
    Blobfinder(BlobfinderArgs),
    /// Print the YUV ranges of a patch of pixels as the lines of a colour file.
    Pick(PickArgs),
    /// Score a colour file's blobs against labelled frames: precision and recall per class;
    /// exit 1 below the given thresholds.
    Check(CheckArgs),
    /// Fit the labelled classes' YUV ranges to labelled frames, from a colour file.
    Fit(FitArgs),
    /// Label the camera frames of a simulator recording from the simulator's ground truth.
    LabelSim(LabelSimArgs),
    /// Open the tuning page: scrub the frames, move the class ranges, mark pixels, see the
    /// blobs over the whole recording, save the colour file.
    Open(OpenArgs),
}

/// Runs `lewis tune`.
///
/// # Errors
/// When an input cannot be read or an output cannot be written.
pub fn run(command: TuneCommand) -> anyhow::Result<ExitCode> {
    match command {
        TuneCommand::Blobfinder(args) => {
            let report = lewis_tune::blobfinder(&args)?;
            print(&report)?;
            report.save_summary()?;
        }
        TuneCommand::Pick(args) => print(&lewis_tune::pick(&args)?)?,
        TuneCommand::Check(args) => {
            let report = lewis_tune::check(&args)?;
            print(&report)?;
            if !report.passed() {
                let mut err = std::io::stderr().lock();
                for failure in report.failures() {
                    writeln!(err, "check failed: {failure}")?;
                }
                return Ok(ExitCode::from(1));
            }
        }
        TuneCommand::Fit(args) => print(&lewis_tune::fit(&args)?)?,
        TuneCommand::LabelSim(args) => print(&lewis_tune::label_sim(&args)?)?,
        TuneCommand::Open(args) => {
            let page = lewis_tune::open(&args)?;
            {
                // The address is how a script (and the browser test) finds the page:
                // flushed now.
                let mut out = std::io::stdout().lock();
                writeln!(
                    out,
                    "lewis tune open: the tuning page is at {} (Ctrl-C to stop)",
                    page.url()
                )?;
                writeln!(out, "{}", page.labels_line())?;
                out.flush()?;
            }
            if !args.no_browser {
                page.open_browser();
            }
            page.wait();
        }
    }
    Ok(ExitCode::SUCCESS)
}

/// Prints a report on stdout, as one write.
fn print(report: &impl std::fmt::Display) -> std::io::Result<()> {
    std::io::stdout()
        .lock()
        .write_all(report.to_string().as_bytes())
}
