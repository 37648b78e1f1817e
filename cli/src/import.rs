//! `lewis import carmen LOG[.gz] -o OUT.mcap`: a real log of another robot software as a
//! Lewis recording that `lewis replay` runs services over.

use std::fmt::Write as _;
use std::io::{IsTerminal, Write as _};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use lewis_recorder::Compression;
use lewis_replay::import::carmen::{
    CarmenImport, ImportOptions, ImportReport, SonarOptions, TimePolicy,
};
use lewis_replay::import::record::{WriteOptions, Written, write_carmen};

/// The formats `lewis import` reads.
#[derive(Debug, Subcommand)]
pub enum ImportCommand {
    /// A CARMEN log (FLASER or ROBOTLASER1, ODOM, PARAM lines; plain or gzip): the laser as
    /// a RangeFinder provider, odometry as Egomotion, a sonar-like fallback derived from the
    /// laser, and the services replay re-simulates over them (Distance, ObstacleAvoider to a
    /// goal, VectorMover).
    Carmen(CarmenArgs),
}

/// Arguments of `lewis import carmen`.
#[derive(Debug, Args)]
#[command(
    after_help = "Broken timestamps (backwards, zero, negative, printed as \
    1.13486e+09) are re-timed from the file order and the scan rate, and the import says \
    what it did; with --strict-time such a log is refused instead. Time never goes \
    backwards in the recording.\n\nExit codes: 0 imported; 2 the log could not be imported."
)]
pub struct CarmenArgs {
    /// The log (`.log` or `.log.gz`).
    #[arg(value_name = "LOG")]
    pub log: PathBuf,
    /// The recording to write (default: the log's name with `.mcap`, in the current folder).
    #[arg(short, long, value_name = "OUT.mcap")]
    pub output: Option<PathBuf>,
    /// Import only the log up to its Nth laser scan.
    #[arg(long, value_name = "N")]
    pub limit_scans: Option<u64>,
    /// The goal of the imported ObstacleAvoider, in the odometry frame, in m (default: the
    /// odometry pose farthest from the start).
    #[arg(long, value_name = "X,Y", value_parser = parse_point, allow_hyphen_values = true)]
    pub goal: Option<(f64, f64)>,
    /// Derive no sonar-like fallback from the laser.
    #[arg(long)]
    pub no_sonar: bool,
    /// Refuse a log whose scan timestamps are broken instead of re-timing it.
    #[arg(long)]
    pub strict_time: bool,
    /// Chunk compression: zstd, lz4 or none.
    #[arg(long, default_value = "zstd", value_name = "KIND")]
    pub compression: Compression,
    /// Split the recording into parts of this much log time, as `4s` or `1m` (with a parts
    /// index `STEM.parts.json` that replay takes as one run).
    #[arg(long, value_name = "DURATION", value_parser = lewis_stdx::parse_duration_ns)]
    pub split_duration: Option<i64>,
}

fn parse_point(text: &str) -> Result<(f64, f64), String> {
    let parsed = text.split_once(',').and_then(|(x, y)| {
        let x: f64 = x.trim().parse().ok()?;
        let y: f64 = y.trim().parse().ok()?;
        (x.is_finite() && y.is_finite()).then_some((x, y))
    });
    parsed.ok_or_else(|| format!("`{text}` is not a point: give X,Y in m, like 12.5,-3"))
}

/// Runs `lewis import`.
pub fn run(command: ImportCommand) -> anyhow::Result<ExitCode> {
    match command {
        ImportCommand::Carmen(args) => carmen(&args),
    }
}

fn carmen(args: &CarmenArgs) -> anyhow::Result<ExitCode> {
    let mut options = ImportOptions {
        max_scans: args.limit_scans,
        goal: args.goal,
        ..ImportOptions::default()
    };
    if args.no_sonar {
        options.sonar = None;
    } else {
        options.sonar = Some(SonarOptions::default());
    }
    if args.strict_time {
        options.timing.policy = TimePolicy::RejectBrokenScans;
    }
    let output = args
        .output
        .clone()
        .unwrap_or_else(|| default_output(&args.log));
    let mut write = WriteOptions::new(&output);
    write.compression = args.compression;
    if let Some(ns) = args.split_duration {
        anyhow::ensure!(ns > 0, "--split-duration 0s: give a duration above 0");
        write.split_duration_ns = Some(ns);
    }
    let import = CarmenImport::open(&args.log, options)?;
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new_spinner();
        bar.set_style(
            ProgressStyle::with_template("importing {spinner} {msg} ({elapsed})")
                .unwrap_or_else(|_| ProgressStyle::default_spinner()),
        );
        bar
    });
    let written = write_carmen(&import, &write, &mut |n| {
        if let Some(bar) = &bar {
            bar.set_message(format!("{n} messages"));
        }
    });
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let written = written.with_context(|| format!("importing {}", args.log.display()))?;
    let text = summary(import.report(), &written);
    std::io::stdout().lock().write_all(text.as_bytes())?;
    Ok(ExitCode::SUCCESS)
}

/// `NAME.mcap` for `DIR/NAME.log.gz`, in the current folder (the logs' folder may be
/// read-only).
fn default_output(log: &Path) -> PathBuf {
    let file = log
        .file_name()
        .map_or_else(|| "import".to_owned(), |f| f.to_string_lossy().into_owned());
    let stem = file.strip_suffix(".gz").unwrap_or(&file);
    let stem = stem.strip_suffix(".log").unwrap_or(stem);
    PathBuf::from(format!("{stem}.mcap"))
}

// For display only.
fn secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}

/// What the import did, for people: the log, the laser, the time policy's findings and
/// actions, what was made up, and what was written.
fn summary(report: &ImportReport, written: &Written) -> String {
    let mut t = String::new();
    let laser = &report.laser;
    let scans: u64 = laser.beam_counts.values().sum();
    let _ = writeln!(
        t,
        "read {}{}: {} lines, {scans} {} scans of {} beams{}, {} odometry lines",
        report.path.display(),
        if report.gzip { " (gzip)" } else { "" },
        report.counts.lines,
        laser.source.line_type(),
        laser.beams(),
        laser
            .rate_hz
            .map(|r| format!(" at {r:.2} Hz"))
            .unwrap_or_default(),
        report.counts.odometry,
    );
    let timing = &report.timing;
    if timing.is_clean() {
        let _ = writeln!(
            t,
            "timestamps: all {} kept as logged",
            timing.scans.total + timing.odometry.total
        );
    } else {
        let _ = writeln!(
            t,
            "timestamps: {} of {} scan and {} of {} odometry stamps kept; time never goes backwards in the recording",
            timing.scans.kept, timing.scans.total, timing.odometry.kept, timing.odometry.total
        );
    }
    for warning in report.warnings() {
        let _ = writeln!(t, "warning: {warning}");
    }
    let _ = writeln!(
        t,
        "robot: sources laser, base{}; re-simulated by `lewis replay`: distance, obstacle_avoider (goal {:.2},{:.2}), vector_mover",
        if report.sonar.is_some() {
            ", sonar (derived)"
        } else {
            ""
        },
        report.goal.0,
        report.goal.1
    );
    let files: Vec<String> = written
        .recording
        .parts
        .iter()
        .map(|p| p.display().to_string())
        .collect();
    let (start, end) = written.span_ns.unwrap_or((0, 0));
    let _ = writeln!(
        t,
        "wrote {}{}: {} messages over {:.1} s",
        files.join(", "),
        written
            .recording
            .index
            .as_ref()
            .map(|i| format!(" (parts index {})", i.display()))
            .unwrap_or_default(),
        written.messages.values().sum::<u64>(),
        secs(end - start)
    );
    for (topic, count) in &written.messages {
        let _ = writeln!(t, "  {topic}: {count}");
    }
    t
}
