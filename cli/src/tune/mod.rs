//! `lewis tune`: offline tuning of colour classes on recorded or saved images.
//!
//! - `lewis tune blobfinder RUN.mcap|IMAGES --colors FILE [--channel TOPIC] [-o OUT.mcap]
//!   [--png DIR] [--signs]` re-runs CMVision with the colour file (and, with `--signs`, the
//!   sign detector, whose board and arrow classes are the file's `White` and `Black`) over
//!   the ImageSource messages of a recording (or the PNG and JPEG files of a folder or
//!   glob), prints per-colour statistics, and with `-o` writes an MCAP file, through the
//!   recorder, that holds the images unchanged and the results on their own channels
//!   (`/tune/blobfinder/Blobs`, `/tune/sign_detector/Signs`), each result naming its image
//!   in its provenance: `lewis view OUT.mcap` draws them over the images. `--png DIR`
//!   writes each frame with its blobs drawn in as PNG instead (or as well).
//! - `lewis tune pick IMAGE|RUN.mcap@T [X,Y] [--rect X,Y,W,H]` prints the YUV ranges of a
//!   patch of pixels of an image file, or of the recorded image shown at T seconds into a
//!   recording, as the two lines of a Player colour file.
//! - `lewis tune check RUN.mcap|IMAGES --colors FILE --labels FILE.json` scores the colour
//!   file's blobs against labelled frames (precision and recall per class) and exits 1
//!   below `--min-precision`/`--min-recall` (`check.rs`).
//! - `lewis tune fit RUN.mcap|IMAGES --colors START --labels FILE.json -o OUT` fits the
//!   labelled classes' ranges to the labels (`fit.rs`).
//! - `lewis tune label-sim RUN.mcap -o FILE.json` labels a simulator recording's frames
//!   from the simulator's ground truth (`label_sim.rs`).
//! - `lewis tune open RUN.mcap|IMAGES --colors FILE [--labels FILE.json]` serves the tuning
//!   page on 127.0.0.1 (`open/`), where boxes labelled by hand are saved for `check` and
//!   `fit`.
//!
//! The perception work is done by `lewis_perception::tuning`; recordings are read
//! with `lewis_replay::recording` and written with `lewis_recorder`. This module wires them.

mod check;
mod fit;
mod frames;
mod label_sim;
mod open;
mod output;
mod pick;

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use lewis_perception::ColorConfig;
use lewis_perception::sign_detector::{self, SignDetector};
use lewis_perception::tuning::{Tuner, save_png};

pub use check::CheckArgs;
pub use fit::FitArgs;
pub use label_sim::LabelSimArgs;
pub use open::OpenArgs;
pub use pick::PickArgs;

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

/// Arguments of `lewis tune blobfinder`.
#[derive(Debug, Args)]
pub struct BlobfinderArgs {
    /// An MCAP recording with ImageSource messages, or a folder or glob of PNG/JPEG files.
    pub input: String,
    /// The colour file (Player's format, or TOML when it ends in .toml).
    #[arg(long)]
    pub colors: PathBuf,
    /// Only this image topic of the recording (default: every ImageSource topic).
    #[arg(long)]
    pub channel: Option<String>,
    /// Write the images and the results (Blobs, and Signs with --signs) into this MCAP file.
    #[arg(short, long, value_name = "OUT.mcap")]
    pub output: Option<PathBuf>,
    /// Write each frame with its blobs drawn in, as PNG, and summary.txt into this folder.
    #[arg(long, value_name = "DIR")]
    pub png: Option<PathBuf>,
    /// Also run the sign detector, with the colour file's `White` and `Black` classes.
    #[arg(long)]
    pub signs: bool,
}

/// Runs `lewis tune`.
///
/// # Errors
/// When an input cannot be read or an output cannot be written.
pub fn run(command: TuneCommand) -> anyhow::Result<ExitCode> {
    match command {
        TuneCommand::Blobfinder(args) => blobfinder(&args),
        TuneCommand::Pick(args) => pick::run(&args),
        TuneCommand::Check(args) => check::run(&args),
        TuneCommand::Fit(args) => fit::run(&args),
        TuneCommand::LabelSim(args) => label_sim::run(&args),
        TuneCommand::Open(args) => open::run(&args),
    }
}

fn tuner(args: &BlobfinderArgs) -> anyhow::Result<Tuner> {
    let colors = ColorConfig::load(&args.colors)?;
    let tuner = Tuner::new(&colors)?;
    if !args.signs {
        return Ok(tuner);
    }
    let params = sign_detector::Params {
        colors: Some(args.colors.clone()),
        ..sign_detector::Params::default()
    };
    let finder = params
        .finder()
        .with_context(|| format!("--signs with {}", args.colors.display()))?;
    Ok(tuner.with_signs(SignDetector::new(
        finder,
        params.mounts(),
        params.horizontal_fov_deg.to_radians(),
    )))
}

fn blobfinder(args: &BlobfinderArgs) -> anyhow::Result<ExitCode> {
    let mut tuner = tuner(args)?;
    let input = frames::Input::open(&args.input, args.channel.as_deref())?;
    if let Some(dir) = &args.png {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create output folder {}", dir.display()))?;
    }
    let mut out = args
        .output
        .as_deref()
        .map(|path| output::TuneOutput::create(path, &input, args.signs))
        .transpose()?;
    let (mut frames, mut skipped, mut signs) = (0u64, 0u64, 0u64);
    for frame in input.frames()? {
        let frame = frame?;
        let tuned = match tuner.frame(&frame.image) {
            Ok(tuned) => tuned,
            Err(e) => {
                tracing::warn!("{}: {e}: skipped", frame.name);
                skipped += 1;
                continue;
            }
        };
        frames += 1;
        signs += tuned.signs.as_ref().map_or(0, |s| s.signs.len() as u64);
        if let Some(out) = &mut out {
            out.write(&frame, &tuned)?;
        }
        if let Some(dir) = &args.png {
            let path = dir.join(format!("{}.png", frame.name));
            let annotated = tuner.annotate(&frame.image, &tuned)?;
            save_png(&annotated, &path)
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
    }
    if frames == 0 {
        anyhow::bail!(
            "{}: no readable image{}{}",
            args.input,
            args.channel
                .as_deref()
                .map(|c| format!(" on {c}"))
                .unwrap_or_default(),
            if skipped > 0 {
                format!(" ({skipped} could not be read)")
            } else {
                String::new()
            }
        );
    }
    let mut summary = format!(
        "{frames} frames of {} with {}{}\n",
        args.input,
        args.colors.display(),
        if skipped > 0 {
            format!(" ({skipped} unreadable, skipped)")
        } else {
            String::new()
        }
    );
    for stats in tuner.statistics().colors() {
        writeln!(summary, "{stats}")?;
    }
    if args.signs {
        // counts far below 2^52
        let per_frame = signs as f64 / frames as f64;
        writeln!(summary, "signs: {per_frame:.2} per frame, {signs} in all")?;
    }
    if let Some(out) = out {
        let (path, messages) = out.close()?;
        writeln!(
            summary,
            "wrote {} ({messages} messages): `lewis view {}` shows the results over the images",
            path.display(),
            path.display()
        )?;
    }
    std::io::stdout().lock().write_all(summary.as_bytes())?;
    if let Some(dir) = &args.png {
        let path = dir.join("summary.txt");
        std::fs::write(&path, &summary)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(ExitCode::SUCCESS)
}
