//! `lewis tune fit RUN.mcap|IMAGES --colors START --labels FILE.json -o OUT`: the YUV
//! ranges of the labelled classes that score best on the labelled frames
//! (`lewis_perception::fitting`), starting from a colour file, and how much better they are.
//! `--held-out FILE.json` scores both files on other labelled frames too, which the fit
//! never saw: the honest measure of what it gained.

use std::collections::BTreeSet;
use std::fmt::{self, Write as _};
use std::path::{Path, PathBuf};

use anyhow::Context as _;
use clap::Args;
use lewis_perception::ColorConfig;
use lewis_perception::fitting::{self, LabelledImage};
use lewis_perception::labels::Labels;
use lewis_perception::scoring::Score;
use lewis_perception::tuning::rgb_image;

use crate::check::{labelled_classes, load_labels};
use crate::frames::Input;

/// Arguments of `lewis tune fit`.
#[derive(Debug, Args)]
pub struct FitArgs {
    /// An MCAP recording with ImageSource messages, or a folder or glob of PNG/JPEG files.
    pub input: String,
    /// The colour file to start from (Player's format, or TOML when it ends in .toml).
    #[arg(long)]
    pub colors: PathBuf,
    /// The labelled frames to fit on.
    #[arg(long)]
    pub labels: PathBuf,
    /// Labelled frames not to fit on, scored before and after.
    #[arg(long, value_name = "LABELS.json")]
    pub held_out: Option<PathBuf>,
    /// Fit only these classes (default: every class the labels label).
    #[arg(long, value_delimiter = ',')]
    pub classes: Vec<String>,
    /// Only this image topic of the recording (default: every ImageSource topic).
    #[arg(long)]
    pub channel: Option<String>,
    /// The fitted colour file to write (Player's format).
    #[arg(short, long, value_name = "OUT.txt")]
    pub output: PathBuf,
}

/// What `lewis tune fit` did: its `Display` is the report it prints (the classes fitted,
/// the mean F1 and each class's score before and after, on the fitted and the held-out
/// frames, the file written).
#[derive(Debug, Clone)]
pub struct FitReport {
    report: String,
}

impl fmt::Display for FitReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.report)
    }
}

/// Runs `lewis tune fit`: fits the classes and writes the fitted colour file.
///
/// # Errors
/// When an input cannot be read or does not fit the others, or the output cannot be
/// written.
pub fn fit(args: &FitArgs) -> anyhow::Result<FitReport> {
    anyhow::ensure!(
        !args
            .output
            .extension()
            .is_some_and(|e| e.eq_ignore_ascii_case("toml")),
        "-o {}: fit writes Player's colour format; give a name that does not end in .toml",
        args.output.display()
    );
    let start = ColorConfig::load(&args.colors)?;
    let labels = load_labels(&args.labels, &start)?;
    let held_out = args
        .held_out
        .as_deref()
        .map(|path| load_labels(path, &start))
        .transpose()?;
    let fitted_names = if args.classes.is_empty() {
        labelled_classes(&start, &labels)
    } else {
        args.classes.clone()
    };
    let fitted: Vec<usize> = fitted_names
        .iter()
        .map(|name| {
            start
                .colors
                .iter()
                .position(|c| &c.name == name)
                .with_context(|| {
                    format!(
                        "--classes {name}: not a class of {}; its classes are {}",
                        args.colors.display(),
                        start
                            .colors
                            .iter()
                            .map(|c| c.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", ")
                    )
                })
        })
        .collect::<anyhow::Result<_>>()?;
    anyhow::ensure!(
        !fitted.is_empty(),
        "{}: labels no object of any class of {}: nothing to fit",
        args.labels.display(),
        args.colors.display()
    );
    if let Some(held_out) = &held_out {
        let fitted_frames: BTreeSet<&str> =
            labels.frames.iter().map(|f| f.frame.as_str()).collect();
        if let Some(both) = held_out
            .frames
            .iter()
            .find(|f| fitted_frames.contains(f.frame.as_str()))
        {
            anyhow::bail!(
                "frame {} is in both {} and --held-out {}: held-out frames must be others",
                both.frame,
                args.labels.display(),
                args.held_out.as_deref().unwrap_or(Path::new("")).display()
            );
        }
    }

    let images = labelled_images(&args.input, args.channel.as_deref(), &labels, &args.labels)?;
    let fit = fitting::fit(&start, &images, labels.min_area_px, &fitted)?;
    let mut report = format!(
        "fitted {} on {} labelled frames of {} from {} ({} colour files scored)\n",
        fitted_names.join(", "),
        images.len(),
        args.input,
        args.colors.display(),
        fit.evaluations
    );
    compare(
        &mut report,
        "fitted frames",
        &fit.before,
        &fit.after,
        &fitted_names,
    );
    if let (Some(held_out), Some(path)) = (&held_out, &args.held_out) {
        let images = labelled_images(&args.input, args.channel.as_deref(), held_out, path)?;
        let before = fitting::score(&start, &images, held_out.min_area_px)?;
        let after = fitting::score(&fit.config, &images, held_out.min_area_px)?;
        let what = format!("{} held-out frames ({})", images.len(), path.display());
        // Judged on the fitted classes that the held-out frames label: a class with no
        // truth there has no recall to gain.
        let judged: Vec<String> = labelled_classes(&start, held_out)
            .into_iter()
            .filter(|c| fitted_names.contains(c))
            .collect();
        compare(&mut report, &what, &before, &after, &judged);
    }
    let comment = format!(
        "Fitted by `lewis tune fit` from {} on the frames of {} labelled in {}\n(classes fitted: {})",
        args.colors.display(),
        args.input,
        args.labels.display(),
        fitted_names.join(", ")
    );
    std::fs::write(&args.output, fit.config.to_player_string(&comment))
        .with_context(|| format!("cannot write {}", args.output.display()))?;
    writeln!(report, "wrote {}", args.output.display())?;
    Ok(FitReport { report })
}

/// Appends the mean F1 of `classes` before and after, and each one's before and after.
fn compare(report: &mut String, what: &str, before: &Score, after: &Score, classes: &[String]) {
    let mean = |score: &Score| {
        let f1: f64 = classes
            .iter()
            .filter_map(|c| score.class(c))
            .map(lewis_perception::scoring::ClassScore::f1)
            .sum();
        // a handful of classes
        f1 / classes.len().max(1) as f64
    };
    let (b, a) = (mean(before), mean(after));
    let _ = writeln!(report, "{what}: mean F1 {b:.3} -> {a:.3} ({:+.3})", a - b);
    for name in classes {
        if let (Some(b), Some(a)) = (before.class(name), after.class(name)) {
            let _ = writeln!(report, "  before {b}\n  after  {a}");
        }
    }
}

/// The frames of `input` that `labels` labels, decoded, with their labels.
fn labelled_images(
    input: &str,
    channel: Option<&str>,
    labels: &Labels,
    labels_path: &Path,
) -> anyhow::Result<Vec<LabelledImage>> {
    let frames = Input::open(input, channel)?;
    let mut images = Vec::new();
    let mut first_name = None;
    for frame in frames.frames()? {
        let frame = frame?;
        first_name.get_or_insert_with(|| frame.name.clone());
        let Some(labelled) = labels.frame(&frame.name) else {
            continue;
        };
        let rgb = rgb_image(&frame.image)
            .map_err(|e| anyhow::anyhow!("{input}: frame {}: {e}", frame.name))?;
        images.push(LabelledImage {
            width_px: rgb.width(),
            height_px: rgb.height(),
            rgb: rgb.into_raw(),
            labels: labelled.clone(),
        });
    }
    if let Some(missing) = labels
        .frames
        .iter()
        .find(|f| !images.iter().any(|i| i.labels.frame == f.frame))
    {
        anyhow::bail!(
            "{}: frame {} is not a frame of {input}{}",
            labels_path.display(),
            missing.frame,
            first_name
                .map(|n| format!(" (its frames are named like {n})"))
                .unwrap_or_default()
        );
    }
    Ok(images)
}
