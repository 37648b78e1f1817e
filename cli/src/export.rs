//! `lewis export ros2 RUN.mcap -o OUT.mcap`: a Lewis recording with companion channels of
//! ROS 2's standard types, for Foxglove and RViz.

use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, Subcommand, ValueEnum};
use lewis_replay::export::ros2::{ExportOptions, ExportReport, ImageCodec, export};

/// The formats `lewis export` writes.
#[derive(Debug, Subcommand)]
pub enum ExportCommand {
    /// The recording with companion channels of ROS 2's standard types beside its own:
    /// LaserScan (uniform RangeFinders), PointCloud2 (the sonar), Odometry, tf and
    /// tf_static, and with --images CompressedImage.
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
    let options = ExportOptions {
        images: args.images.map(|i| match i {
            ImagesArg::Png => ImageCodec::Png,
            ImagesArg::Jpeg => ImageCodec::Jpeg,
        }),
    };
    let report = export(&args.input, &args.output, &options)
        .with_context(|| format!("exporting {}", args.input.display()))?;
    let text = summary(&args.output, &report);
    std::io::stdout().lock().write_all(text.as_bytes())?;
    Ok(ExitCode::SUCCESS)
}

/// What was written, for people.
fn summary(output: &std::path::Path, report: &ExportReport) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "{}: {} messages copied on {} channels, with ROS 2 companions:",
        output.display(),
        report.copied,
        report.copied_channels
    );
    for (topic, (type_name, count)) in &report.companions {
        let _ = writeln!(t, "  {topic:<28} {type_name:<32} {count}");
    }
    for (topic, count) in &report.images_skipped {
        let _ = writeln!(
            t,
            "  images of {topic} not exported ({count}): give --images to add them as CompressedImage"
        );
    }
    for (topic, count) in &report.images_unsupported {
        let _ = writeln!(
            t,
            "  images of {topic} not exported ({count}): only rgb8 and mono8 are compressed"
        );
    }
    t
}
