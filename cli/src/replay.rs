//! `lewis replay RUN.mcap [RUN2.mcap ...]`: deterministic re-simulation of a recording,
//! with faults injected and a comparison with what was recorded.

use lewis_service::ServiceRegistry;
use std::io::{IsTerminal, Write};
use std::path::PathBuf;
use std::process::ExitCode;

use anyhow::Context as _;
use clap::Args;
use indicatif::{ProgressBar, ProgressStyle};
use lewis_replay::fault::{FaultKind, FaultSpec, REPLAY_FAULTS};
use lewis_replay::resim::edit::{EditError, ParamEdit};
use lewis_replay::resim::{
    DEFAULT_TOLERANCE, Progress, ReplayOptions, ServiceSelection, default_output, replay_with,
};
use lewis_replay::sweep::{SweepSpec, sweep};

/// Arguments of `lewis replay`.
#[derive(Debug, Args)]
#[command(
    after_help = "Fault SPECs: PROVIDER[@START[-END]][:KIND], KIND one of \
    crash, stall (the default), garbage, frozen, slow, out-of-service, stuck, host-lost; times \
    from the start of the recording (12.5s, 12.5 or 500ms). `laser` stalls the provider named laser \
    half-way through; `laser@12.5s-20s:crash` crashes it for a window, then lets it recover. \
    A robot on more than one host loses a host named: `workstation@12s-20s` cuts it off, \
    its services with it, and it joins again at 20 s.\n\n\
    Regression check of a change: `lewis replay RUN.mcap --check` replays the services as \
    the recording stores them; `--robot robots/sim.toml` replays with the repository's \
    robot file instead, `--set obstacle_avoider.clearance_m=0.3` with one parameter \
    changed. Unchanged services reproduce their recorded outputs exactly. With `--all` \
    living a mission again, --check compares its states and outcome; --check-outputs the \
    outputs too.\n\n\
    Exit codes: 0 replayed (and, with --check, what it compares matches); 1 --check found \
    outputs beyond the tolerance or a mission gone otherwise; 2 the replay could not run."
)]
pub struct ReplayArgs {
    /// The recording (several files: parts of one run, merged in time order).
    #[arg(required = true, value_name = "RUN.mcap")]
    pub inputs: Vec<PathBuf>,
    /// The output recording (default: RUN.replay.mcap beside the first input).
    #[arg(short, long, value_name = "OUT.mcap")]
    pub output: Option<PathBuf>,
    /// Re-simulate these services (comma-separated) instead of every non-source service.
    #[arg(
        long,
        value_delimiter = ',',
        conflicts_with = "all",
        value_name = "A,B"
    )]
    pub services: Option<Vec<String>>,
    /// Live the run again whole (closed loop): the simulated devices re-run from the
    /// recorded world, the services, the broker, and the recorded mission's sequencer and
    /// programs; the report ends with the mission's verdict beside the recorded one. A
    /// recording whose sources are real devices is replayed open loop, and says so.
    #[arg(long)]
    pub all: bool,
    /// Inject a fault (repeat for several). Its time is within the recording, or, with
    /// `--all` living a mission again, up to as long again past its end (the mission may
    /// arrive later than it did live).
    #[arg(long = "inject-fault", value_name = "SPEC", value_parser = parse_fault)]
    pub faults: Vec<FaultSpec>,
    /// Replay with this robot description instead of the one stored in the recording
    /// (typically the repository's robot file after the change under test).
    #[arg(long, value_name = "ROBOT.toml")]
    pub robot: Option<PathBuf>,
    /// Change a parameter of a re-simulated service for this replay (repeat for several);
    /// VALUE is TOML, a bare word a string.
    #[arg(long = "set", value_name = "SERVICE.PARAMETER=VALUE", value_parser = parse_set)]
    pub set: Vec<ParamEdit>,
    /// Write only what the replay produced (the `/replay/...` channels) to the output, not
    /// a copy of the recorded channels: the recording holds them already, and the output
    /// is then the size of the re-simulated part alone. Compared and reported the same.
    #[arg(long)]
    pub outputs_only: bool,
    /// Do not write the channels of this interface to the output, recorded or re-simulated
    /// (repeat for several); still compared. `--leave-out ImageSource` drops the camera
    /// frames, most of a recording's bytes.
    #[arg(long = "leave-out", value_name = "INTERFACE", value_parser = parse_interface)]
    pub left_out: Vec<String>,
    /// Exit 1 when re-simulated outputs differ from the recorded ones beyond the tolerance;
    /// with `--all` living a mission again, when its states or outcome differ from the
    /// recorded ones (the outputs not compared: see --check-outputs).
    #[arg(long)]
    pub check: bool,
    /// As --check, and with `--all` living a mission again, the re-simulated outputs are
    /// compared with the recorded ones too; the channels beyond the tolerance are listed.
    #[arg(long)]
    pub check_outputs: bool,
    /// The absolute tolerance on numbers for --check.
    #[arg(long, default_value_t = DEFAULT_TOLERANCE, value_name = "X")]
    pub tolerance: f64,
    /// Also write the report as JSON to this file.
    #[arg(long, value_name = "FILE.json")]
    pub report: Option<PathBuf>,
    /// Print the report as JSON on stdout instead of text.
    #[arg(long)]
    pub json: bool,
    /// Sweep a fault across the run: these providers fail together at --steps times, one
    /// closed-loop replay each; the table is printed and written as JSON (--report, else
    /// RUN.sweep.json) and as a plot (the same name, .png).
    #[arg(
        long = "sweep-fault",
        value_delimiter = ',',
        value_name = "A,B",
        requires = "all",
        conflicts_with_all = ["check", "check_outputs", "output", "json"]
    )]
    pub sweep_fault: Option<Vec<String>>,
    /// How many fault times a sweep tries, spread evenly across the run.
    #[arg(long, default_value_t = 20, value_parser = clap::value_parser!(u32).range(1..), requires = "sweep_fault")]
    pub steps: u32,
    /// How a sweep's providers fail: crash, stall, garbage, frozen, slow, out-of-service or
    /// stuck.
    #[arg(long, default_value = "crash", value_parser = parse_kind, requires = "sweep_fault")]
    pub kind: FaultKind,
    /// Replays a sweep runs at once (default: one per core).
    #[arg(long, value_name = "N", value_parser = clap::value_parser!(u32).range(1..), requires = "sweep_fault")]
    pub jobs: Option<u32>,
}

fn parse_kind(text: &str) -> Result<FaultKind, String> {
    let no_kind = |near: String| {
        format!(
            "`{text}` is no fault kind: give {}{near}",
            REPLAY_FAULTS.names()
        )
    };
    match REPLAY_FAULTS.parse(text) {
        Ok(Some(kind)) => Ok(kind),
        // Replay has no word for no fault.
        Ok(None) => Err(no_kind(String::new())),
        Err(unknown) => Err(no_kind(unknown.did_you_mean())),
    }
}

/// `text` when it names an interface (`ImageSource`), else which names there are.
fn parse_interface(text: &str) -> Result<String, String> {
    if lewis_interfaces::interface_info(text).is_some() {
        return Ok(text.to_owned());
    }
    let known: Vec<&str> = lewis_interfaces::msg::INTERFACES
        .iter()
        .map(|i| i.name)
        .collect();
    Err(format!(
        "`{text}` is no interface: give one of {}",
        known.join(", ")
    ))
}

fn parse_set(text: &str) -> Result<ParamEdit, String> {
    text.parse().map_err(|e: EditError| e.to_string())
}

fn parse_fault(text: &str) -> Result<FaultSpec, String> {
    text.parse()
        .map_err(|e: lewis_replay::fault::FaultError| e.to_string())
}

/// Runs `lewis replay`.
pub fn run(args: &ReplayArgs, registry: &ServiceRegistry) -> anyhow::Result<ExitCode> {
    let mut options = ReplayOptions::new(args.inputs.clone());
    options.output = Some(
        args.output
            .clone()
            .unwrap_or_else(|| default_output(&args.inputs[0])),
    );
    options.services = match (&args.services, args.all) {
        (_, true) => ServiceSelection::All,
        (Some(names), false) => ServiceSelection::Only(names.clone()),
        (None, false) => ServiceSelection::NonSources,
    };
    options.faults.clone_from(&args.faults);
    options.robot.clone_from(&args.robot);
    options.set.clone_from(&args.set);
    options.tolerance = args.tolerance;
    options.outputs_only = args.outputs_only;
    options.left_out = args.left_out.iter().cloned().collect();
    options.check_outputs = args.check_outputs;
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(1000);
        bar.set_style(
            ProgressStyle::with_template(
                "replaying {bar:40} {percent:>3}% {msg} ({elapsed} elapsed, {eta} left)",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    });
    let mut on_progress = |p: Progress| {
        if let Some(bar) = &bar {
            let permille = if p.total_ns > 0 {
                u64::try_from(p.done_ns.saturating_mul(1000) / p.total_ns).unwrap_or(0)
            } else {
                1000
            };
            bar.set_position(permille.min(1000));
            bar.set_message(format!(
                "{:.1}s of {:.1}s, {} messages",
                secs(p.done_ns),
                secs(p.total_ns),
                p.messages
            ));
        }
    };
    let programs = crate::app::programs();
    if let Some(providers) = &args.sweep_fault {
        return run_sweep(args, &options, registry, providers);
    }
    let report = replay_with(&options, registry, Some(&programs), &mut on_progress);
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let report = report?;
    if let Some(path) = &args.report {
        let json = serde_json::to_string_pretty(&report)?;
        std::fs::write(path, json + "\n")
            .with_context(|| format!("cannot write the report to {}", path.display()))?;
    }
    let mut out = std::io::stdout().lock();
    if args.json {
        serde_json::to_writer_pretty(&mut out, &report)?;
        writeln!(out)?;
    } else {
        writeln!(out, "{report}")?;
    }
    let checked = args.check || args.check_outputs;
    Ok(if checked && !report.check.passed {
        ExitCode::FAILURE
    } else {
        ExitCode::SUCCESS
    })
}

/// `--sweep-fault`: the sweep, its table on stdout, its JSON and its plot.
fn run_sweep(
    args: &ReplayArgs,
    options: &ReplayOptions,
    registry: &ServiceRegistry,
    providers: &[String],
) -> anyhow::Result<ExitCode> {
    let jobs = args.jobs.map_or_else(
        || std::thread::available_parallelism().map_or(1, std::num::NonZero::get),
        |n| n as usize,
    );
    let spec = SweepSpec {
        providers: providers.to_vec(),
        kind: args.kind,
        steps: args.steps,
        jobs,
    };
    let bar = std::io::stderr().is_terminal().then(|| {
        let bar = ProgressBar::new(u64::from(args.steps));
        bar.set_style(
            ProgressStyle::with_template(
                "sweeping {bar:40} {pos}/{len} replays ({elapsed} elapsed, {eta} left)",
            )
            .unwrap_or_else(|_| ProgressStyle::default_bar()),
        );
        bar
    });
    let done = |count: usize| {
        if let Some(bar) = &bar {
            bar.set_position(count as u64);
        }
    };
    let result = sweep(options, registry, &crate::app::programs(), &spec, &done);
    if let Some(bar) = &bar {
        bar.finish_and_clear();
    }
    let swept = result?;
    let json = args
        .report
        .clone()
        .unwrap_or_else(|| sweep_output(&args.inputs[0], "json"));
    std::fs::write(&json, swept.to_json())
        .with_context(|| format!("cannot write the sweep to {}", json.display()))?;
    let png = json.with_extension("png");
    swept.write_png(&png)?;
    let mut out = std::io::stdout().lock();
    writeln!(out, "{swept}")?;
    writeln!(out, "written: {} and {}", json.display(), png.display())?;
    Ok(ExitCode::SUCCESS)
}

/// `RUN.sweep.EXT` beside `RUN.mcap`.
fn sweep_output(input: &std::path::Path, extension: &str) -> PathBuf {
    let stem = input
        .file_stem()
        .map_or_else(|| "run".to_owned(), |s| s.to_string_lossy().into_owned());
    input.with_file_name(format!("{stem}.sweep.{extension}"))
}

// For display only.
fn secs(ns: i64) -> f64 {
    ns as f64 / 1e9
}
