//! `lewis tune`: offline tuning of colour classes on recorded or saved images.
//!
//! - `lewis tune blobfinder RUN.mcap|IMAGES --colors FILE [--channel TOPIC] [-o OUT]`
//!   re-runs CMVision with the colour file over the ImageSource messages of a recording
//!   (or the PNG and JPEG files of a folder or glob), prints per-colour statistics and, with
//!   `-o`, writes each frame with its blob boxes drawn into OUT/ as PNG, plus summary.txt.
//! - `lewis tune pick IMAGE X,Y [--radius R] [--margin M]` prints the threshold line of the
//!   colour around a pixel, in the colour file's format.
//!
//! The work is done by `lewis_services::perception::tuning`; this module reads the inputs
//! and prints.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use lewis_interfaces::Struct as _;
use lewis_interfaces::msg::ImageSource;
use lewis_services::camera::sequence::resolve;
use lewis_services::perception::ColorConfig;
use lewis_services::perception::tuning::{Tuner, pick_in_file};

/// `lewis tune ...`
#[derive(Debug, Subcommand)]
pub enum TuneCommand {
    /// Re-run the blob finder with a colour file over recorded or saved images.
    Blobfinder(BlobfinderArgs),
    /// Print the YUV threshold line of the colour around a pixel of an image.
    Pick(PickArgs),
}

/// Arguments of `lewis tune blobfinder`.
#[derive(Debug, Args)]
pub struct BlobfinderArgs {
    /// An MCAP recording with ImageSource messages, or a folder or glob of PNG/JPEG files.
    pub input: String,
    /// The colour file (Player's format, or TOML when it ends in .toml).
    #[arg(long)]
    pub colors: PathBuf,
    /// Only this topic of the recording (default: every ImageSource channel).
    #[arg(long)]
    pub channel: Option<String>,
    /// A folder to write the annotated frames (PNG) and summary.txt into.
    #[arg(short, long)]
    pub output: Option<PathBuf>,
}

/// Arguments of `lewis tune pick`.
#[derive(Debug, Args)]
pub struct PickArgs {
    /// A PNG or JPEG image.
    pub image: PathBuf,
    /// The pixel, as COLUMN,ROW.
    #[arg(value_parser = parse_pixel)]
    pub pixel: (u32, u32),
    /// Radius of the disc of pixels around it.
    #[arg(long, default_value_t = 6)]
    pub radius: u32,
    /// Levels added on each side of the 5th-95th percentile ranges.
    #[arg(long, default_value_t = 4)]
    pub margin: u8,
}

fn parse_pixel(text: &str) -> Result<(u32, u32), String> {
    let (x, y) = text
        .split_once(',')
        .ok_or_else(|| format!("`{text}` is not COLUMN,ROW (for example 120,45)"))?;
    let parse = |v: &str| {
        v.trim()
            .parse::<u32>()
            .map_err(|_| format!("`{v}` in `{text}` is not a pixel coordinate"))
    };
    Ok((parse(x)?, parse(y)?))
}

/// Runs `lewis tune`.
///
/// # Errors
/// When an input cannot be read or an output cannot be written.
pub fn run(command: TuneCommand) -> anyhow::Result<ExitCode> {
    match command {
        TuneCommand::Blobfinder(args) => blobfinder(&args),
        TuneCommand::Pick(args) => pick(&args),
    }
}

fn pick(args: &PickArgs) -> anyhow::Result<ExitCode> {
    let (x, y) = args.pixel;
    let got = pick_in_file(&args.image, x, y, args.radius, args.margin)?;
    let mut out = std::io::stdout().lock();
    writeln!(
        out,
        "# {} pixels within {} px of {x},{y} in {}: 5th-95th percentiles, widened by {}",
        got.pixels,
        args.radius,
        args.image.display(),
        args.margin
    )?;
    writeln!(out, "{}", got.threshold_line())?;
    Ok(ExitCode::SUCCESS)
}

/// Frames to tune on: a name each (for the PNG written) and the message.
type Frames = Vec<(String, ImageSource)>;

fn blobfinder(args: &BlobfinderArgs) -> anyhow::Result<ExitCode> {
    let colors = ColorConfig::load(&args.colors)?;
    let mut tuner = Tuner::new(&colors)?;
    let input = Path::new(&args.input);
    let frames = if input.is_file()
        && input
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("mcap"))
    {
        recorded_frames(input, args.channel.as_deref())?
    } else {
        image_files(&args.input)?
    };
    if frames.is_empty() {
        anyhow::bail!(
            "{}: no ImageSource messages{}: check the topic with `lewis info`",
            args.input,
            args.channel
                .as_deref()
                .map(|c| format!(" on {c}"))
                .unwrap_or_default()
        );
    }
    if let Some(dir) = &args.output {
        std::fs::create_dir_all(dir)
            .with_context(|| format!("cannot create output folder {}", dir.display()))?;
    }
    let mut skipped = 0;
    for (name, frame) in &frames {
        let tuned = match tuner.frame(frame) {
            Ok(tuned) => tuned,
            Err(e) => {
                tracing::warn!("{name}: {e}: skipped");
                skipped += 1;
                continue;
            }
        };
        if let Some(dir) = &args.output {
            let path = dir.join(format!("{name}.png"));
            tuned
                .save_png(&path)
                .with_context(|| format!("cannot write {}", path.display()))?;
        }
    }
    let mut summary = format!(
        "{} frames of {} with {}{}\n",
        frames.len() - skipped,
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
    std::io::stdout().lock().write_all(summary.as_bytes())?;
    if let Some(dir) = &args.output {
        let path = dir.join("summary.txt");
        std::fs::write(&path, &summary)
            .with_context(|| format!("cannot write {}", path.display()))?;
    }
    Ok(ExitCode::SUCCESS)
}

/// The ImageSource messages of a recording, in file order, named by topic and sequence.
fn recorded_frames(path: &Path, channel: Option<&str>) -> anyhow::Result<Frames> {
    let bytes = std::fs::read(path).with_context(|| format!("cannot read {}", path.display()))?;
    let stream = mcap::MessageStream::new(&bytes)
        .with_context(|| format!("{} is not an MCAP file", path.display()))?;
    let mut frames = Vec::new();
    for message in stream {
        let message = message.with_context(|| format!("{} is damaged", path.display()))?;
        let schema = message.channel.schema.as_ref().map(|s| s.name.as_str());
        if schema != Some(ImageSource::SCHEMA_NAME)
            || channel.is_some_and(|c| c != message.channel.topic)
        {
            continue;
        }
        let image: ImageSource =
            lewis_interfaces::cdr::from_bytes(&message.data).with_context(|| {
                format!(
                    "{}: message {} on {} does not decode as ImageSource",
                    path.display(),
                    message.sequence,
                    message.channel.topic
                )
            })?;
        let topic: String = message
            .channel
            .topic
            .trim_matches('/')
            .chars()
            .map(|c| if c.is_ascii_alphanumeric() { c } else { '_' })
            .collect();
        frames.push((format!("{topic}-{:06}", image.header.seq), image));
    }
    Ok(frames)
}

/// The PNG and JPEG files of a folder or glob, in name order, named by file stem.
fn image_files(source: &str) -> anyhow::Result<Frames> {
    resolve(source)?
        .into_iter()
        .map(|path| {
            let image = Tuner::read_image(&path)?;
            let name = path
                .file_stem()
                .map_or_else(|| "frame".to_owned(), |s| s.to_string_lossy().into_owned());
            Ok((name, image))
        })
        .collect()
}
