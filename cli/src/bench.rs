//! `lewis bench`: measures run by hand, whose figures go into the README's Speed section.
//!
//! - `lewis bench replay RUN.mcap [--runs N]`: replay speed as a multiple of real time,
//!   beside the lockstep harness alone and the same services called directly.
//! - `lewis bench long-recording REF.mcap -o LONG.mcap [--size-mb N]`: a long recording made
//!   of laps of a short one, to measure a replay's peak memory (`/usr/bin/time -v lewis
//!   replay LONG.mcap`).
//! - `lewis bench closed-loop RUN.mcap [--sweep-fault P --steps N --jobs J]`: a mission
//!   lived again as a multiple of real time, beside its handlers' own time, its peak
//!   memory and a sweep's time.
//! - `lewis bench mission --seeds N [--random-start] [--people N]`: the Challenge mission live
//!   from random start poses with people walking about, the laser failing after the door:
//!   its success rate and each failure's state and reason.

use lewis_service::ServiceRegistry;
use std::io::Write;
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::{Args, Subcommand};
use lewis_replay::bench::closed::measure_closed;
use lewis_replay::bench::long::write_long;
use lewis_replay::bench::speed::{SpeedOptions, measure};
use lewis_replay::fault::FaultKind;
use lewis_replay::resim::{ReplayOptions, ServiceSelection};
use lewis_replay::sweep::SweepSpec;

/// The measures.
#[derive(Debug, Subcommand)]
pub enum BenchCommand {
    /// How fast a recording replays: `lewis replay` as a multiple of real time, the lockstep
    /// harness alone, and the same services called directly in a loop with the same inputs.
    Replay(ReplayBenchArgs),
    /// Write a long recording made of laps of a short one (for the memory of a long replay).
    LongRecording(LongArgs),
    /// How fast a whole mission is lived again (`lewis replay --all`), beside its handlers'
    /// own time, its peak memory, and a fault sweep.
    ClosedLoop(ClosedLoopArgs),
    /// The Challenge mission live again and again, from random start poses in the start room
    /// and with people walking about, the laser failing after the door: the success rate,
    /// and each failure's state and reason.
    Mission(MissionArgs),
}

/// Arguments of `lewis bench mission`.
#[derive(Debug, Args)]
pub struct MissionArgs {
    /// How many missions.
    #[arg(long, default_value_t = 20)]
    pub seeds: u32,
    /// Mission i (from 0) draws its start, its people and its devices' noise from SEED + i.
    #[arg(long, default_value_t = 1)]
    pub seed: u64,
    /// Start anywhere in the start room (the robot file's start pose's room), at any
    /// heading; without it, every mission starts where the robot file says.
    #[arg(long)]
    pub random_start: bool,
    /// People who each walk a straight way across the corridors and the hall once, in each
    /// mission.
    #[arg(long, default_value_t = 3)]
    pub people: u32,
    /// The simulated robot.
    #[arg(long, default_value = "robots/sim.toml")]
    pub robot: PathBuf,
    /// The mission script.
    #[arg(long, default_value = "robots/missions/challenge.seq")]
    pub script: PathBuf,
    /// Where bench.json and each failed mission's folder go.
    #[arg(short, long, default_value = lewis_demo::mission_bench::OUT_DIR)]
    pub out: PathBuf,
}

/// Arguments of `lewis bench closed-loop`.
#[derive(Debug, Args)]
pub struct ClosedLoopArgs {
    /// A recording of the simulated robot on a mission (`lewis demo` writes one).
    #[arg(value_name = "RUN.mcap")]
    pub input: PathBuf,
    /// The provider the sweep fails (none: no sweep).
    #[arg(long, value_name = "PROVIDER")]
    pub sweep_fault: Option<String>,
    /// The sweep's fault times.
    #[arg(long, default_value_t = 20)]
    pub steps: u32,
    /// The sweep's threads (default: one per core).
    #[arg(long)]
    pub jobs: Option<usize>,
    /// Print the figures as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `lewis bench replay`.
#[derive(Debug, Args)]
pub struct ReplayBenchArgs {
    /// The recording.
    #[arg(value_name = "RUN.mcap")]
    pub input: PathBuf,
    /// Runs of each measure; the best is kept.
    #[arg(long, default_value_t = 5)]
    pub runs: usize,
    /// Print the figures as JSON.
    #[arg(long)]
    pub json: bool,
}

/// Arguments of `lewis bench long-recording`.
#[derive(Debug, Args)]
pub struct LongArgs {
    /// The recording to repeat.
    #[arg(value_name = "REF.mcap")]
    pub input: PathBuf,
    /// The long recording.
    #[arg(short, long, value_name = "LONG.mcap")]
    pub output: PathBuf,
    /// At least this many megabytes (10^6 bytes).
    #[arg(long, default_value_t = 1100, value_name = "MB")]
    pub size_mb: u64,
}

fn closed_loop(args: &ClosedLoopArgs, registry: ServiceRegistry) -> anyhow::Result<ExitCode> {
    let scratch =
        std::env::temp_dir().join(format!("lewis-bench-closed-{}.mcap", std::process::id()));
    let mut replay = ReplayOptions::new(vec![args.input.clone()]);
    replay.output = Some(scratch.clone());
    replay.services = ServiceSelection::All;
    let sweep = args.sweep_fault.as_ref().map(|provider| SweepSpec {
        providers: vec![provider.clone()],
        kind: FaultKind::Crash,
        steps: args.steps,
        jobs: args.jobs.unwrap_or_else(|| {
            std::thread::available_parallelism().map_or(1, std::num::NonZero::get)
        }),
    });
    let report = measure_closed(
        &replay,
        &std::sync::Arc::new(registry),
        &crate::app::programs(),
        sweep.as_ref(),
    );
    if report.is_err() {
        let _ = std::fs::remove_file(&scratch);
    }
    print_figures(report?, &scratch, args.json)
}

/// Removes the measure's scratch output, then prints its figures as text or JSON.
fn print_figures(
    report: impl std::fmt::Display + serde::Serialize,
    scratch: &std::path::Path,
    json: bool,
) -> anyhow::Result<ExitCode> {
    // The scratch output is not wanted, whatever happened.
    let _ = std::fs::remove_file(scratch);
    let mut out = std::io::stdout().lock();
    if json {
        writeln!(out, "{}", serde_json::to_string_pretty(&report)?)?;
    } else {
        writeln!(out, "{}", report.to_string().trim_end())?;
    }
    Ok(ExitCode::SUCCESS)
}

/// Runs `lewis bench`.
pub fn run(command: &BenchCommand, registry: ServiceRegistry) -> anyhow::Result<ExitCode> {
    match command {
        BenchCommand::Replay(args) => {
            let scratch = std::env::temp_dir()
                .join(format!("lewis-bench-replay-{}.mcap", std::process::id()));
            let mut replay = ReplayOptions::new(vec![args.input.clone()]);
            replay.output = Some(scratch.clone());
            let options = SpeedOptions {
                replay,
                runs: args.runs,
            };
            let report = measure(&options, &registry);
            if report.is_err() {
                let _ = std::fs::remove_file(&scratch);
            }
            print_figures(report?, &scratch, args.json)
        }
        BenchCommand::ClosedLoop(args) => closed_loop(args, registry),
        BenchCommand::Mission(args) => mission(args, &registry),
        BenchCommand::LongRecording(args) => {
            let mut last = 0;
            let report = write_long(
                &args.input,
                &args.output,
                args.size_mb.saturating_mul(1_000_000),
                &mut |lap, laps| {
                    if lap * 10 / laps != last {
                        last = lap * 10 / laps;
                        // Progress only: a closed stderr changes nothing.
                        let _ = writeln!(std::io::stderr(), "{lap} of {laps} laps written");
                    }
                },
            )
            .with_context(|| format!("cannot make a long recording of {}", args.input.display()))?;
            writeln!(
                std::io::stdout().lock(),
                "wrote {} ({} bytes, {} laps of {}, {} messages, {:.0} s)",
                report.output.display(),
                report.bytes,
                report.laps,
                args.input.display(),
                report.messages,
                nanos_to_secs(report.duration_ns)
            )?;
            Ok(ExitCode::SUCCESS)
        }
    }
}

/// `lewis bench mission`: exit 0 when every mission succeeded.
fn mission(args: &MissionArgs, registry: &ServiceRegistry) -> anyhow::Result<ExitCode> {
    use lewis_demo::mission_bench::{MissionBenchOptions, mission_line, run_mission_bench};
    let options = MissionBenchOptions {
        robot: args.robot.clone(),
        script: args.script.clone(),
        seeds: args.seeds,
        seed: args.seed,
        random_start: args.random_start,
        people: args.people,
        out: args.out.clone(),
        lewis_exe: std::env::current_exe().context("cannot find the lewis executable")?,
        fault: lewis_demo::fault::LiveFault::laser_after_first_state(),
    };
    writeln!(
        std::io::stdout().lock(),
        "mission bench: {} missions{}, {} people walking about, the laser killed after the door; results in {}",
        args.seeds,
        if args.random_start {
            " from random starts"
        } else {
            ""
        },
        args.people,
        args.out.display()
    )?;
    let report = run_mission_bench(&options, registry, &mut |mission| {
        let mut out = std::io::stdout().lock();
        let _ = writeln!(out, "{}", mission_line(mission));
        let _ = out.flush();
    })?;
    let mut out = std::io::stdout().lock();
    write!(out, "{}", report.summary())?;
    writeln!(out, "report: {}", args.out.join("bench.json").display())?;
    Ok(if report.succeeded() == report.missions.len() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}

// For display only.
fn nanos_to_secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}
