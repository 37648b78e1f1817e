//! `lewis tune blobfinder RUN.mcap|IMAGES --colors FILE`: the blob finder (and with
//! `--signs` the sign detector) run again with a colour file over recorded or saved images,
//! with per-colour statistics, and the results written as MCAP (`-o`) or PNG (`--png`).

use std::fmt::{self, Write as _};
use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use lewis_perception::ColorConfig;
use lewis_perception::sign_detector::{self, SignDetector};
use lewis_perception::tuning::{Tuner, save_png};

use crate::frames;
use crate::output;

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

/// What `lewis tune blobfinder` found: its `Display` is the summary it prints (frames,
/// per-colour statistics, signs, the file written).
#[derive(Debug, Clone)]
pub struct BlobfinderReport {
    summary: String,
    /// The `--png` folder, where [`BlobfinderReport::save_summary`] writes `summary.txt`.
    png: Option<PathBuf>,
}

impl fmt::Display for BlobfinderReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.summary)
    }
}

impl BlobfinderReport {
    /// Writes the summary as `summary.txt` beside the PNG files, with `--png`; does
    /// nothing without.
    ///
    /// # Errors
    /// When the file cannot be written.
    pub fn save_summary(&self) -> anyhow::Result<()> {
        if let Some(dir) = &self.png {
            let path = dir.join("summary.txt");
            std::fs::write(&path, &self.summary)
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
        Ok(())
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

/// Runs `lewis tune blobfinder`: every frame through the blob finder, the MCAP and PNG
/// files written; the summary returned (and not yet saved: see
/// [`BlobfinderReport::save_summary`]).
///
/// # Errors
/// When an input cannot be read, no frame can, or an output cannot be written.
pub fn blobfinder(args: &BlobfinderArgs) -> anyhow::Result<BlobfinderReport> {
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
    Ok(BlobfinderReport {
        summary,
        png: args.png.clone(),
    })
}
