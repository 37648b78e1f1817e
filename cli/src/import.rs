//! `lewis import carmen LOG[.gz] -o OUT.mcap` and `lewis import ros2 BAG.mcap`: a real log of
//! another robot software as a Lewis recording that `lewis replay` runs services over.

use std::fmt::Write as _;
use std::io::{IsTerminal, Write as _};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use indicatif::{ProgressBar, ProgressStyle};
use lewis_formats::import::carmen::{
    CarmenImport, ImportOptions, ImportReport, SonarOptions, TimePolicy,
};
use lewis_formats::import::record::{WriteOptions, Written, write_carmen, write_ros2};
use lewis_formats::import::ros2;
use lewis_recorder::Compression;

/// The formats `lewis import` reads.
#[derive(Debug, Subcommand)]
pub enum ImportCommand {
    /// A CARMEN log (FLASER or ROBOTLASER1, ODOM, PARAM lines; plain or gzip): the laser as
    /// a RangeFinder provider, odometry as Egomotion, a sonar-like fallback derived from the
    /// laser, and the services replay re-simulates over them (Distance, ObstacleAvoider to a
    /// goal, VectorMover).
    Carmen(CarmenArgs),
    /// A ROS 2 bag (rosbag2 MCAP): sensor_msgs/LaserScan as a RangeFinder (and Distance),
    /// nav_msgs/Odometry (or odom to base_link on /tf) as Egomotion, sensor_msgs/Image and
    /// CompressedImage as ImageSource, the bag's messages kept beside them, and the services
    /// replay can re-simulate over what was found.
    Ros2(Ros2Args),
}

/// Arguments of `lewis import ros2`.
#[derive(Debug, Args)]
#[command(
    after_help = "Topics are chosen by type when the bag has one of a type; with several,     the import stops and lists them: say which with --map TOPIC=RangeFinder,     TOPIC=Egomotion or TOPIC=ImageSource (a second RangeFinder map is the laser's     fallback). The recording's times are the bag's log times; header stamps are compared     to them in the report. Nothing is written under OUT.mcap unless the import completes.\n\n    Exit codes: 0 imported; 2 the bag could not be imported."
)]
pub struct Ros2Args {
    /// The bag (one `.mcap` file).
    #[arg(value_name = "BAG.mcap")]
    pub bag: PathBuf,
    /// The recording to write (default: `BAG-lewis.mcap` in the current folder).
    #[arg(short, long, value_name = "OUT.mcap")]
    pub output: Option<PathBuf>,
    /// Which topic gives which interface: RangeFinder, Egomotion or ImageSource.
    #[arg(long = "map", value_name = "TOPIC=INTERFACE", value_parser = parse_map)]
    pub maps: Vec<(String, String)>,
    /// The goal of the imported ObstacleAvoider, in the odometry frame, in m (default: the
    /// odometry pose farthest from the start).
    #[arg(long, value_name = "X,Y", value_parser = parse_point, allow_hyphen_values = true)]
    pub goal: Option<(f64, f64)>,
    /// Derive no sonar-like fallback from the laser.
    #[arg(long)]
    pub no_sonar: bool,
    /// A colour file (Player's format or TOML): the robot gets a `blobfinder` over the
    /// bag's camera, whose Blobs the import computes for `lewis replay --check`.
    #[arg(long, value_name = "FILE")]
    pub colors: Option<PathBuf>,
    /// Chunk compression: zstd, lz4 or none.
    #[arg(long, default_value = "zstd", value_name = "KIND")]
    pub compression: Compression,
}

fn parse_map(text: &str) -> Result<(String, String), String> {
    let (topic, interface) = text
        .split_once('=')
        .ok_or_else(|| format!("`{text}` is not TOPIC=INTERFACE, like /scan=RangeFinder"))?;
    if !ros2::topics::MAPPABLE.contains(&interface) {
        return Err(format!(
            "`{interface}`: give one of {}",
            ros2::topics::MAPPABLE.join(", ")
        ));
    }
    Ok((topic.to_owned(), interface.to_owned()))
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
        ImportCommand::Ros2(args) => ros2_bag(&args),
    }
}

fn ros2_bag(args: &Ros2Args) -> anyhow::Result<ExitCode> {
    let options = ros2::ImportOptions {
        maps: args.maps.clone(),
        goal: args.goal,
        sonar: (!args.no_sonar).then(SonarOptions::default),
        colors: args.colors.clone(),
        ..ros2::ImportOptions::default()
    };
    let output = args.output.clone().unwrap_or_else(|| {
        let file = args
            .bag
            .file_name()
            .map_or_else(|| "bag".to_owned(), |f| f.to_string_lossy().into_owned());
        let stem = file.strip_suffix(".mcap").unwrap_or(&file);
        PathBuf::from(format!("{stem}-lewis.mcap"))
    });
    let import = ros2::Ros2Import::open(&args.bag, &options)?;
    let written = write_ros2(&import, &output, args.compression, &mut |_| {})
        .with_context(|| format!("importing {}", args.bag.display()))?;
    let text = ros2_summary(import.report(), &written);
    std::io::stdout().lock().write_all(text.as_bytes())?;
    Ok(ExitCode::SUCCESS)
}

/// What a ROS 2 import did, for people.
fn ros2_summary(report: &ros2::ImportReport, written: &Written) -> String {
    let mut t = String::new();
    let _ = writeln!(
        t,
        "read {}: {} topics",
        report.path.display(),
        report.topics.len()
    );
    for topic in &report.topics {
        let _ = writeln!(
            t,
            "  {} ({}): {} messages{}",
            topic.topic.name,
            topic.topic.type_name,
            topic.count,
            topic
                .rate_hz()
                .map(|r| format!(" at {r:.1} Hz"))
                .unwrap_or_default()
        );
    }
    if let Some(laser) = &report.laser {
        let _ = writeln!(
            t,
            "laser: {} -> /laser/RangeFinder: {} scans of {} beams, max range {:.2} m",
            laser.topic, laser.scans, laser.beams, laser.max_range_m
        );
    }
    if let Some(laser) = &report.second_laser {
        let _ = writeln!(
            t,
            "second range sensor: {} -> /laser2/RangeFinder: {} scans of {} beams",
            laser.topic, laser.scans, laser.beams
        );
    }
    if let Some(o) = &report.odometry {
        let _ = writeln!(
            t,
            "odometry: {} -> /base/Egomotion: {} readings",
            o.topic, o.readings
        );
    }
    if let Some(i) = &report.image {
        let kinds: Vec<String> = i
            .encodings
            .iter()
            .map(|(k, n)| format!("{n} {k}"))
            .collect();
        let _ = writeln!(
            t,
            "camera: {} -> /camera/ImageSource (rgb8): {} images of {}x{} ({})",
            i.topic,
            i.images,
            i.size_px.0,
            i.size_px.1,
            kinds.join(", ")
        );
    }
    for (topic, s) in &report.stamps {
        let offsets = s
            .offset_range_ns
            .map(|(lo, hi)| {
                format!(
                    ", log time minus stamp {:.3} to {:.3} s",
                    secs(lo),
                    secs(hi)
                )
            })
            .unwrap_or_default();
        let _ = writeln!(
            t,
            "timestamps: {topic}: {} header stamps{offsets}; the recording keeps the log times",
            s.stamped
        );
    }
    for warning in report.warnings() {
        let _ = writeln!(t, "warning: {warning}");
    }
    let mut resim = Vec::new();
    if report.colors.is_some() {
        resim.push("blobfinder".to_owned());
    }
    if report.laser.is_some() {
        resim.push("distance".to_owned());
    }
    if ros2::has_avoider(report) {
        resim.push(format!(
            "obstacle_avoider (goal {:.2},{:.2}), vector_mover",
            report.goal.0, report.goal.1
        ));
    }
    let _ = writeln!(
        t,
        "robot: re-simulated by `lewis replay`: {}",
        if resim.is_empty() {
            "nothing (no laser: the import keeps the odometry for viewing and comparison)"
                .to_owned()
        } else {
            resim.join(", ")
        }
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
        "wrote {}: {} messages over {:.1} s",
        files.join(", "),
        written.messages.values().sum::<u64>(),
        secs(end - start)
    );
    for (topic, count) in &written.messages {
        let _ = writeln!(t, "  {topic}: {count}");
    }
    t
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
