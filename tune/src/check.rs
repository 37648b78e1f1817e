//! `lewis tune check RUN.mcap|IMAGES --colors FILE --labels FILE.json`: precision and recall
//! of a colour file's blobs per class over the labelled frames, and an exit code that
//! makes the colour file a regression test.
//!
//! Only the classes that the labels file labels somewhere are scored: a class nobody
//! labelled has no truth to be judged by.

use std::collections::BTreeSet;
use std::fmt::{self, Write as _};
use std::path::PathBuf;

use clap::Args;
use lewis_perception::ColorConfig;
use lewis_perception::labels::Labels;
use lewis_perception::scoring::{Mistake, Score};
use lewis_perception::tuning::Tuner;

use crate::frames::Input;

/// Arguments of `lewis tune check`.
#[derive(Debug, Args)]
pub struct CheckArgs {
    /// An MCAP recording with ImageSource messages, or a folder or glob of PNG/JPEG files.
    pub input: String,
    /// The colour file (Player's format, or TOML when it ends in .toml).
    #[arg(long)]
    pub colors: PathBuf,
    /// The labelled frames (JSON; see `lewis_perception::labels`).
    #[arg(long)]
    pub labels: PathBuf,
    /// Only this image topic of the recording (default: every ImageSource topic).
    #[arg(long)]
    pub channel: Option<String>,
    /// Exit 1 when a scored class's precision is below this (0 to 1).
    #[arg(long, value_name = "P")]
    pub min_precision: Option<f64>,
    /// Exit 1 when a scored class's recall is below this (0 to 1).
    #[arg(long, value_name = "R")]
    pub min_recall: Option<f64>,
    /// Also print each frame's false blobs and missed objects.
    #[arg(long)]
    pub mistakes: bool,
}

/// The classes a labels file labels somewhere, in the colour file's order.
pub(crate) fn labelled_classes(colors: &ColorConfig, labels: &Labels) -> Vec<String> {
    let named: BTreeSet<&str> = labels
        .frames
        .iter()
        .flat_map(|f| f.objects.iter().map(|o| o.class.as_str()))
        .collect();
    colors
        .colors
        .iter()
        .filter(|c| named.contains(c.name.as_str()))
        .map(|c| c.name.clone())
        .collect()
}

/// Loads the labels of `path`, checked against the classes of `colors`.
pub(crate) fn load_labels(path: &std::path::Path, colors: &ColorConfig) -> anyhow::Result<Labels> {
    let classes: Vec<&str> = colors.colors.iter().map(|c| c.name.as_str()).collect();
    Ok(Labels::load(path, &classes)?)
}

/// The score of `colors` over the frames of `input` that `labels` labels.
///
/// # Errors
/// When the input cannot be read, or the labels name a frame that it does not have.
pub(crate) fn score_input(
    input: &str,
    channel: Option<&str>,
    colors: &ColorConfig,
    labels: &Labels,
    labels_path: &std::path::Path,
    mut on_mistakes: impl FnMut(&str, Vec<Mistake>),
) -> anyhow::Result<Score> {
    let mut tuner = Tuner::new(colors)?;
    let frames = Input::open(input, channel)?;
    let mut score = Score::new(colors.colors.iter().map(|c| c.name.as_str()));
    let mut found = BTreeSet::new();
    let mut first_name = None;
    for frame in frames.frames()? {
        let frame = frame?;
        first_name.get_or_insert_with(|| frame.name.clone());
        let Some(labelled) = labels.frame(&frame.name) else {
            continue;
        };
        let tuned = tuner
            .frame(&frame.image)
            .map_err(|e| anyhow::anyhow!("{input}: frame {}: {e}", frame.name))?;
        let mistakes = score.add_frame(&tuned.regions, labelled, labels.min_area_px);
        if !mistakes.is_empty() {
            on_mistakes(&frame.name, mistakes);
        }
        found.insert(labelled.frame.clone());
    }
    if let Some(missing) = labels.frames.iter().find(|f| !found.contains(&f.frame)) {
        anyhow::bail!(
            "{}: frame {} is not a frame of {input}{}",
            labels_path.display(),
            missing.frame,
            first_name
                .map(|n| format!(" (its frames are named like {n})"))
                .unwrap_or_default()
        );
    }
    Ok(score)
}

/// What `lewis tune check` found: its `Display` is the report it prints (the frames, each
/// scored class's precision and recall, the classes not scored, with `--mistakes` each
/// frame's); [`CheckReport::failures`] are the thresholds missed.
#[derive(Debug, Clone)]
pub struct CheckReport {
    report: String,
    failures: Vec<String>,
}

impl fmt::Display for CheckReport {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(&self.report)
    }
}

impl CheckReport {
    /// The thresholds missed (`Red precision 0.812 is below 0.9`), one a class and
    /// measure; none when the colour file passes.
    #[must_use]
    pub fn failures(&self) -> &[String] {
        &self.failures
    }

    /// Whether every scored class met the thresholds.
    #[must_use]
    pub fn passed(&self) -> bool {
        self.failures.is_empty()
    }
}

/// Runs `lewis tune check`: the score of the colour file over the labelled frames.
///
/// # Errors
/// When an input cannot be read or does not fit the others.
pub fn check(args: &CheckArgs) -> anyhow::Result<CheckReport> {
    for (flag, value) in [
        ("--min-precision", args.min_precision),
        ("--min-recall", args.min_recall),
    ] {
        if let Some(v) = value {
            anyhow::ensure!(
                (0.0..=1.0).contains(&v),
                "{flag} {v}: give a share from 0 to 1"
            );
        }
    }
    let colors = ColorConfig::load(&args.colors)?;
    let labels = load_labels(&args.labels, &colors)?;
    let scored = labelled_classes(&colors, &labels);
    let mut report = String::new();
    let mut wrong = String::new();
    let score = score_input(
        &args.input,
        args.channel.as_deref(),
        &colors,
        &labels,
        &args.labels,
        |frame, mistakes| {
            if args.mistakes {
                for mistake in mistakes.iter().filter(|m| scored.contains(&m.class)) {
                    let _ = writeln!(wrong, "{frame}: {mistake}");
                }
            }
        },
    )?;
    writeln!(
        report,
        "{} labelled frames of {} with {} ({})",
        score.frames(),
        args.input,
        args.colors.display(),
        args.labels.display()
    )?;
    let mut failures = Vec::new();
    for class in score.classes() {
        if !scored.contains(&class.name) {
            continue;
        }
        writeln!(report, "{class}")?;
        for (what, value, min) in [
            ("precision", class.precision(), args.min_precision),
            ("recall", class.recall(), args.min_recall),
        ] {
            if let (Some(min), value) = (min, value.unwrap_or(0.0))
                && value < min
            {
                failures.push(format!("{} {what} {value:.3} is below {min}", class.name));
            }
        }
    }
    let unscored: Vec<&str> = colors
        .colors
        .iter()
        .map(|c| c.name.as_str())
        .filter(|name| !scored.iter().any(|s| s == name))
        .collect();
    if !unscored.is_empty() {
        writeln!(report, "not labelled, not scored: {}", unscored.join(", "))?;
    }
    report.push_str(&wrong);
    Ok(CheckReport { report, failures })
}
