//! `lewis import carmen LOG[.gz] -o OUT.mcap`: a CARMEN log as a Lewis recording (the laser as
//! a RangeFinder provider, the odometry as Egomotion, a sonar-like fallback derived from the
//! laser, and the robot description that says so), written by the recorder.

use std::collections::BTreeMap;
use std::fmt::Write as _;
use std::io::Write as _;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::{Context as _, bail};
use clap::{Args, Subcommand};
use lewis_recorder::{ChannelId, ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};
use lewis_replay::import::carmen::{self, CarmenImport, ImportError, ImportOptions, robot_toml};

/// The formats `lewis import` reads.
#[derive(Debug, Subcommand)]
pub enum ImportCommand {
    /// A CARMEN log (FLASER or ROBOTLASER1, ODOM and PARAM lines; plain or gzip).
    Carmen(CarmenArgs),
}

/// Arguments of `lewis import carmen`.
#[derive(Debug, Args)]
#[command(
    after_help = "Broken timestamps (zero, negative, not finite, backwards, too coarse) are \
    re-timed: the import says how many and what it did, and time never goes backwards in \
    the recording. The provider `sonar` is derived from the laser (fewer, wider beams, \
    shorter range, lower rate and quality) so that `lewis replay OUT.mcap --inject-fault \
    laser` has something to fail over to; --no-sonar leaves it out."
)]
pub struct CarmenArgs {
    /// The log.
    #[arg(value_name = "LOG[.gz]")]
    pub log: PathBuf,
    /// The recording to write (must not exist).
    #[arg(short, long, value_name = "OUT.mcap")]
    pub output: PathBuf,
    /// Do not derive the sonar-like fallback from the laser.
    #[arg(long)]
    pub no_sonar: bool,
}

/// Runs `lewis import`.
pub fn run(command: &ImportCommand) -> anyhow::Result<ExitCode> {
    match command {
        ImportCommand::Carmen(args) => carmen_to_mcap(args),
    }
}

fn carmen_to_mcap(args: &CarmenArgs) -> anyhow::Result<ExitCode> {
    if args.output.exists() {
        bail!(
            "{} exists: choose another output, the import never overwrites",
            args.output.display()
        );
    }
    let mut options = ImportOptions::default();
    if args.no_sonar {
        options.sonar = None;
    }
    let import = CarmenImport::open(&args.log, options).map_err(|e| said(&e))?;
    let report = import.report();
    let mut recorder_options = RecorderOptions::new(&args.output);
    recorder_options.robot_description = Some(RobotDescription {
        file_name: format!("{}.toml", carmen::robot::robot_name(&args.log)),
        toml: robot_toml(report),
    });
    let mut recorder = Recorder::create(recorder_options)
        .with_context(|| format!("cannot create {}", args.output.display()))?;
    let mut channels: BTreeMap<String, ChannelId> = BTreeMap::new();
    let mut per_channel: BTreeMap<String, u64> = BTreeMap::new();
    let mut data = Vec::new();
    let mut messages = import.messages().map_err(|e| said(&e))?;
    let written = (|| -> anyhow::Result<()> {
        for message in &mut messages {
            let message = message.map_err(|e| said(&e))?;
            let channel = match channels.get(&message.channel) {
                Some(channel) => *channel,
                None => {
                    let interface = message.payload.interface();
                    let info = lewis_interfaces::interface_info(interface)
                        .with_context(|| format!("no interface named {interface}"))?;
                    let spec = ChannelSpec::publication(
                        info,
                        &message.payload.header().provider,
                        &message.channel,
                    );
                    let id = recorder.add_channel(spec)?;
                    channels.insert(message.channel.clone(), id);
                    id
                }
            };
            message.payload.encode_to_vec(&mut data);
            recorder.write(&Sample {
                channel,
                seq: message.payload.header().seq,
                publish_time_ns: message.time_ns,
                log_time_ns: message.time_ns,
                data: &data,
            })?;
            *per_channel.entry(message.channel).or_default() += 1;
        }
        Ok(())
    })();
    // The file is closed with its summary even when the log ends in an error, so that what
    // was written can be read; the error is still reported.
    let closed = recorder.close();
    written.with_context(|| format!("importing {}", args.log.display()))?;
    closed.with_context(|| format!("closing {}", args.output.display()))?;

    let mut text = String::new();
    let _ = writeln!(
        text,
        "imported {} into {}: {:.1} s",
        args.log.display(),
        args.output.display(),
        nanos_to_secs(report.timing.end_ns - report.timing.start_ns)
    );
    for (channel, count) in &per_channel {
        let _ = writeln!(text, "  {channel}: {count}");
    }
    for warning in report.warnings() {
        let _ = writeln!(text, "note: {warning}");
    }
    let _ = std::io::stdout().lock().write_all(text.as_bytes());
    Ok(ExitCode::SUCCESS)
}

/// The import's errors carry their cause in their own text: printed as a chain, it would
/// be said twice.
fn said(error: &ImportError) -> anyhow::Error {
    anyhow::anyhow!("{error}")
}

// For display only.
#[allow(clippy::cast_precision_loss)]
fn nanos_to_secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}
