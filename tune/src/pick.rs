//! `lewis tune pick IMAGE|RUN.mcap@T [X,Y] [--rect X,Y,W,H]`: the YUV ranges of a patch of
//! pixels, printed as the two lines of a Player colour file, to start a colour class from.

use std::fmt;
use std::path::PathBuf;

use anyhow::Context as _;
use clap::Args;
use lewis_interfaces::msg::ImageSource;
use lewis_perception::tuning::{self, Patch, Pick, pick_in_file, rgb_image};

use crate::frames::Input;

/// Arguments of `lewis tune pick`.
#[derive(Debug, Args)]
#[command(group(clap::ArgGroup::new("patch").required(true).args(["pixel", "rect"])))]
pub struct PickArgs {
    /// A PNG or JPEG image, or a recording and a time into it: `RUN.mcap@12.5s` (the image
    /// shown then: the last one recorded at or before it).
    #[arg(value_parser = parse_source)]
    pub source: Source,
    /// A pixel, as COLUMN,ROW: the disc of --radius around it.
    #[arg(value_parser = parse_pixel)]
    pub pixel: Option<(u32, u32)>,
    /// A rectangle instead: its top-left pixel and its size, COLUMN,ROW,WIDTH,HEIGHT.
    #[arg(long, value_name = "X,Y,W,H", value_parser = parse_rect, conflicts_with = "pixel")]
    pub rect: Option<(u32, u32, u32, u32)>,
    /// Radius of the disc around PIXEL.
    #[arg(long, default_value_t = 6)]
    pub radius: u32,
    /// Levels added on each side of the 5th-95th percentile ranges.
    #[arg(long, default_value_t = 4)]
    pub margin: u8,
    /// The image topic of a recording (default: its only one; required when it has more).
    #[arg(long)]
    pub channel: Option<String>,
    /// The name of the colour class in the printed lines.
    #[arg(long, default_value = "Picked")]
    pub name: String,
}

/// What to pick from.
#[derive(Debug, Clone, PartialEq)]
pub enum Source {
    /// An image file.
    Image(PathBuf),
    /// A recording, and seconds from its first message.
    Recording(PathBuf, f64),
}

fn parse_source(text: &str) -> Result<Source, String> {
    let Some((file, time)) = text.rsplit_once('@') else {
        return Ok(Source::Image(PathBuf::from(text)));
    };
    let seconds = time
        .strip_suffix('s')
        .unwrap_or(time)
        .parse::<f64>()
        .ok()
        .filter(|s| s.is_finite() && *s >= 0.0)
        .ok_or_else(|| {
            format!("`{time}` in `{text}` is not a time: give seconds from the start, e.g. RUN.mcap@12.5s")
        })?;
    Ok(Source::Recording(PathBuf::from(file), seconds))
}

fn numbers<const N: usize>(text: &str, what: &str) -> Result<[u32; N], String> {
    let values: Vec<&str> = text.split(',').collect();
    let bad = || format!("`{text}` is not {what}");
    let values: Vec<u32> = values
        .iter()
        .map(|v| v.trim().parse::<u32>().map_err(|_| bad()))
        .collect::<Result<_, _>>()?;
    values.try_into().map_err(|_| bad())
}

fn parse_pixel(text: &str) -> Result<(u32, u32), String> {
    let [x, y] = numbers(text, "COLUMN,ROW (for example 120,45)")?;
    Ok((x, y))
}

fn parse_rect(text: &str) -> Result<(u32, u32, u32, u32), String> {
    let [x, y, w, h] = numbers(text, "COLUMN,ROW,WIDTH,HEIGHT (for example 120,45,20,10)")?;
    Ok((x, y, w, h))
}

impl PickArgs {
    fn patch(&self) -> Patch {
        match (self.rect, self.pixel) {
            (Some((x, y, width, height)), _) => Patch::Rect {
                x,
                y,
                width,
                height,
            },
            (None, Some((x, y))) => Patch::Disc {
                x,
                y,
                radius_px: self.radius,
            },
            // clap requires one of them.
            (None, None) => Patch::Rect {
                x: 0,
                y: 0,
                width: 0,
                height: 0,
            },
        }
    }
}

/// What `lewis tune pick` found: its `Display` is what it prints, two comment lines
/// (pixels and ranges) and the lines of a Player colour file.
#[derive(Debug, Clone)]
pub struct PickReport {
    /// The ranges picked.
    pub pick: Pick,
    /// The pixels they were picked from.
    pub patch: Patch,
    /// The image they were picked from (a file, or a recording's topic, seq and time).
    pub from: String,
    /// The levels added on each side.
    pub margin: u8,
    /// The colour class's name in the colour file's lines.
    pub name: String,
}

impl fmt::Display for PickReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let got = &self.pick;
        writeln!(
            f,
            "# {} pixels of {} in {}: 5th-95th percentiles, widened by {}",
            got.pixels, self.patch, self.from, self.margin
        )?;
        writeln!(
            f,
            "# Y {}..{}  U {}..{}  V {}..{}",
            got.y.lo, got.y.hi, got.u.lo, got.u.hi, got.v.lo, got.v.hi
        )?;
        writeln!(f, "[Colors]\n{}", got.color_line(&self.name))?;
        writeln!(f, "[Thresholds]\n{}", got.threshold_line())
    }
}

/// Runs `lewis tune pick`: the YUV ranges of the patch.
///
/// # Errors
/// When the image or recording cannot be read or the patch is not in the image.
pub fn pick(args: &PickArgs) -> anyhow::Result<PickReport> {
    let patch = args.patch();
    let (got, from) = match &args.source {
        Source::Image(path) => (
            pick_in_file(path, patch, args.margin)?,
            path.display().to_string(),
        ),
        Source::Recording(path, seconds) => {
            let (image, said) = recorded_image(path, *seconds, args.channel.as_deref())?;
            let rgb = rgb_image(&image).with_context(|| said.clone())?;
            (
                tuning::pick(&rgb, patch, args.margin).with_context(|| said.clone())?,
                said,
            )
        }
    };
    Ok(PickReport {
        pick: got,
        patch,
        from,
        margin: args.margin,
        name: args.name.clone(),
    })
}

/// The image shown `seconds` after the first message of a recording: the last one
/// recorded at or before then. Also says which it is.
fn recorded_image(
    path: &std::path::Path,
    seconds: f64,
    channel: Option<&str>,
) -> anyhow::Result<(ImageSource, String)> {
    let input = Input::open(&path.display().to_string(), channel)?;
    let Input::Recording {
        recording, topics, ..
    } = &input
    else {
        anyhow::bail!("{} is not an MCAP recording", path.display());
    };
    anyhow::ensure!(
        topics.len() == 1,
        "{} has {} image topics ({}): choose one with --channel",
        path.display(),
        topics.len(),
        topics
            .iter()
            .map(|t| t.name.to_string())
            .collect::<Vec<_>>()
            .join(", ")
    );
    let start_ns = recording.start_ns();
    // seconds of a recording, far below 2^63 ns
    let at_ns = start_ns.saturating_add((seconds * 1e9).round() as i64);
    let mut shown = None;
    for frame in input.frames()? {
        let frame = frame?;
        if frame.log_time_ns > at_ns && shown.is_some() {
            break;
        }
        shown = Some(frame);
    }
    let Some(frame) = shown else {
        anyhow::bail!("{} has no image", path.display());
    };
    // nanoseconds of a recording
    let when_s = (frame.log_time_ns - start_ns) as f64 / 1e9;
    let said = format!(
        "{} {} seq {} at {when_s:.3} s",
        path.display(),
        frame.topic,
        frame.image.header.seq
    );
    Ok((frame.image, said))
}
