//! `lewis view`: a recording in the Rerun viewer.

use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::bail;
use clap::Args;
use lewis_viewer::{
    RERUN_SDK_PIP_VERSION, Target, ViewOptions, default_rrd_path, rerun_on_path, view,
};

/// `lewis view RUN.mcap [more.mcap ...] [--save OUT.rrd | --spawn | --connect ADDR]`
#[derive(Debug, Args)]
#[command(
    long_about = "Shows a recording in the Rerun viewer: poses, paths and scans in the world \
                  and in the robot frame, camera images with blobs, broker decisions, health, \
                  logs, and every numeric field as a plot, on the recording's log_time and \
                  publish_time timelines. Without --save, --spawn or --connect it starts the \
                  `rerun` viewer when it is on the PATH, and otherwise writes RUN.rrd next to \
                  the first recording."
)]
pub struct ViewArgs {
    /// The recording; several files are parts of one run, in order (a rotated recording's
    /// parts index, `RUN.parts.json`, stands for its parts).
    #[arg(required = true, value_name = "RUN.mcap")]
    pub files: Vec<PathBuf>,
    /// Write a Rerun file (the same recording always gives the same file).
    #[arg(short = 'o', long = "save", value_name = "OUT.rrd", conflicts_with_all = ["spawn", "connect"])]
    pub save: Option<PathBuf>,
    /// Start the Rerun viewer (`rerun` on the PATH) and send the recording to it.
    #[arg(long, conflicts_with = "connect")]
    pub spawn: bool,
    /// Send the recording to a running Rerun viewer.
    #[arg(long, value_name = "ADDR", num_args = 0..=1,
          default_missing_value = "rerun+http://127.0.0.1:9876/proxy")]
    pub connect: Option<String>,
}

/// Converts and reports; a recording with undecodable messages or damage still exits 0
/// (what could be shown was shown, and the report says what was not).
pub fn run(args: &ViewArgs) -> anyhow::Result<ExitCode> {
    let files = lewis_replay::recording::expand_inputs(&args.files)?;
    let mut hint = false;
    let target = if let Some(path) = &args.save {
        Target::Save(path.clone())
    } else if let Some(address) = &args.connect {
        Target::Connect(address.clone())
    } else if args.spawn || rerun_on_path() {
        Target::Spawn
    } else {
        let Some(first) = files.first() else {
            bail!("no recording given");
        };
        hint = true;
        Target::Save(default_rrd_path(first))
    };
    let options = ViewOptions {
        target: target.clone(),
        progress: true,
    };
    let report = view(&files, &options)?;
    let mut out = std::io::stdout().lock();
    write!(out, "{report}")?;
    if hint && let Target::Save(path) = &target {
        writeln!(
            out,
            "no `rerun` viewer on the PATH: install it with `pip install rerun-sdk=={RERUN_SDK_PIP_VERSION}`, \
             then run `rerun {}`",
            path.display()
        )?;
    }
    Ok(ExitCode::SUCCESS)
}
