//! `lewis export ros2 RUN.mcap -o OUT.mcap`: a Lewis recording with companion channels of
//! ROS 2's standard types, for Foxglove and RViz.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Subcommand, ValueEnum};
use lewis_formats::export::ros2::{ExportReport, export};
use lewis_recorder::companion::{CompanionOptions, ImageCodec};

/// The formats `lewis export` writes.
#[derive(Debug, Subcommand)]
pub enum ExportCommand {
    /// The recording with companion channels of ROS 2's standard types beside its own:
    /// LaserScan (uniform RangeFinders), PointCloud2 (the sonar), Odometry, tf and
    /// tf_static, MarkerArray (blobs, signs, the broker's bindings), and with --images
    /// CompressedImage.
    Ros2(Ros2ExportArgs),
}

/// How images are compressed.
#[derive(Debug, Clone, Copy, ValueEnum)]
pub enum ImagesArg {
    /// Lossless.
    Png,
    /// Lossy, smaller.
    Jpeg,
}

impl From<ImagesArg> for ImageCodec {
    fn from(arg: ImagesArg) -> Self {
        match arg {
            ImagesArg::Png => Self::Png,
            ImagesArg::Jpeg => Self::Jpeg,
        }
    }
}

/// Arguments of `lewis export ros2`.
#[derive(Debug, Args)]
#[command(
    after_help = "Every channel of the recording is copied unchanged. Nothing is written under OUT.mcap unless the export completes.\n\nExit codes: 0 exported; 2 the recording could not be exported."
)]
pub struct Ros2ExportArgs {
    /// The Lewis recording (one `.mcap` file).
    #[arg(value_name = "RUN.mcap")]
    pub input: PathBuf,
    /// The file to write.
    #[arg(short, long, value_name = "OUT.mcap")]
    pub output: PathBuf,
    /// Also write the camera's images as CompressedImage (png unless jpeg is given); left
    /// out by default, since a second copy of every frame doubles the file.
    #[arg(long, value_name = "FORMAT", num_args = 0..=1, default_missing_value = "png")]
    pub images: Option<ImagesArg>,
}

/// Runs `lewis export`.
pub fn run(command: ExportCommand) -> anyhow::Result<ExitCode> {
    match command {
        ExportCommand::Ros2(args) => ros2(&args),
    }
}

fn ros2(args: &Ros2ExportArgs) -> anyhow::Result<ExitCode> {
    let options = CompanionOptions {
        images: args.images.map(ImageCodec::from),
    };
    let report = export(&args.input, &args.output, options)?;
    let text = summary(&args.output, &report);
    std::io::stdout().lock().write_all(text.as_bytes())?;
    Ok(ExitCode::SUCCESS)
}

/// What was written, for people.
fn summary(output: &Path, report: &ExportReport) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "{}: {} messages copied, with ROS 2 companions:",
        output.display(),
        report.copied,
    );
    for (topic, (type_name, count)) in &report.companions {
        let _ = writeln!(t, "  {topic:<28} {type_name:<36} {count}");
    }
    for (topic, count) in &report.images_left_out {
        let _ = writeln!(
            t,
            "  {topic}: {count} images left out (give --images to add them as CompressedImage)"
        );
    }
    for (topic, skipped) in &report.skipped {
        let _ = writeln!(
            t,
            "  {topic}: {} messages without a companion: {}",
            skipped.count, skipped.reason
        );
    }
    t
}
