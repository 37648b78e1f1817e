//! The `lewis` command line: clap definitions and the dispatch to the library crates.
//! Every behaviour lives in a library crate; this one parses, calls, and prints.
//!
//! Exit codes: 0 success; 1 the command ran and found problems (invalid definitions,
//! a failed check); 2 the command could not run (bad arguments, unreadable files).

use lewis_service::ServiceRegistry;
use std::process::ExitCode;

use clap::{Parser, Subcommand};
use lewis_runtime::logs::Verbosity;

mod app;
mod bench;
mod demo;
mod error_text;
mod export;
mod fake_device;
mod fault;
mod goal;
mod idl;
mod import;
mod info;
mod play;
mod record;
mod recover;
mod replay;
mod seq;
mod service;
mod status;
mod stress;
mod suite;
mod tune;
mod up;
#[cfg(feature = "viewer")]
mod view;
mod world;

pub use error_text::error_text;

/// The `lewis` command line.
#[derive(Debug, Parser)]
#[command(
    name = "lewis",
    version,
    about = "Fault-tolerant robot control, recorded and replayed",
    long_about = "Lewis runs robot software as small services that implement interfaces \
                  defined in XML, records every publication into MCAP, and replays \
                  recordings deterministically."
)]
pub struct Cli {
    /// Say more: `-v` shows the broker's every decision and each service's routine lines,
    /// `-vv` what only a developer needs.
    #[arg(short, long, global = true, action = clap::ArgAction::Count)]
    pub verbose: u8,
    /// Say only warnings and errors.
    #[arg(short, long, global = true, conflicts_with = "verbose")]
    pub quiet: bool,
    /// What to do.
    #[command(subcommand)]
    pub command: Command,
}

/// The subcommands.
#[derive(Debug, Subcommand)]
pub enum Command {
    /// Check and show interface definitions.
    #[command(subcommand)]
    Idl(idl::IdlCommand),
    /// Describe an MCAP recording: channels, counts, rates, losses, and decoded messages.
    Info(info::InfoArgs),
    /// Check and run mission scripts (the sequencer).
    #[command(subcommand)]
    Seq(seq::SeqCommand),
    /// Record a running robot into MCAP: every publication, command, decision and log line.
    Record(record::RecordArgs),
    /// Repair a recording whose writer died (SIGKILL, power cut): everything up to its last
    /// complete chunk, with a new summary.
    Recover(recover::RecoverArgs),
    /// Import a log of another robot software (CARMEN) as a Lewis recording that replay runs
    /// services over.
    #[command(subcommand)]
    Import(import::ImportCommand),
    /// Export a Lewis recording for other tools: ROS 2 companion channels (LaserScan,
    /// Odometry, tf) that Foxglove and RViz draw.
    #[command(subcommand)]
    Export(export::ExportCommand),
    /// Re-simulate a recording in lockstep: services and broker on a virtual clock, faults
    /// injected, outputs compared with the recording (a regression test with --check).
    Replay(replay::ReplayArgs),
    /// Replay every recording under the paths as a regression suite, with the fault sweeps
    /// of a faults file: JUnit, JSON and HTML reports; on one machine or as jobs for a
    /// scheduler (--plan, --job, --merge).
    Test(suite::TestArgs),
    /// Publish a recording into live IPC at its recorded pace (like `ros2 bag play`), with a
    /// clock on /lewis/clock; space pauses, `s` steps, `q` quits.
    Play(play::PlayArgs),
    /// Start the broker and a robot's services; run until Ctrl-C or --duration.
    Up(up::UpArgs),
    /// Run one of the Robot Challenge's sub-task programs until it finishes (what the
    /// mission's states start); exits with its code.
    App(app::AppArgs),
    /// The Robot Challenge on the simulated robot: a fault, the verdict, a replay.
    Demo(demo::DemoArgs),
    /// Run one service of a robot in this process (what `lewis up` starts).
    Service(service::ServiceArgs),
    /// Show the broker's services, health, restarts and bindings.
    Status(status::StatusArgs),
    /// Show a recording in the Rerun viewer, or write it as a Rerun file (--save OUT.rrd).
    #[cfg(feature = "viewer")]
    View(view::ViewArgs),
    /// Take a service of a running robot down: kill, stall, freeze, garble or put it out of service.
    Fault(fault::FaultArgs),
    /// Emulate the SICK laser or the RFlex base on a pseudo-terminal and print its path, until
    /// Ctrl-C.
    FakeDevice(fake_device::FakeDeviceArgs),
    /// Tune colour classes offline: re-run the blob finder over recorded or saved images,
    /// pick a colour from an image, score and fit a colour file on labelled frames.
    #[command(subcommand)]
    Tune(tune::TuneCommand),
    /// Publish the recorder's stress mix (a test and measurement tool).
    #[command(hide = true)]
    StressPublish(stress::StressArgs),
    /// Measure: replay speed against real time and against the services called directly,
    /// long recordings for the memory of a replay, the mission's success from random starts.
    #[command(subcommand)]
    Bench(bench::BenchCommand),
    /// Rebuild a simulator world from a real run's laser scans (`from`), and measure how
    /// faithfully it makes them again (`check`).
    #[command(subcommand)]
    World(world::WorldCommand),
}

/// The whole `lewis` command with the service kinds of `registry`: parses the command line,
/// runs it, prints an error, and returns the exit code (2 when the command could not run).
///
/// `lewis`'s own `main` passes `lewis_kinds::registry()`. A team's binary passes that
/// registry with its own kinds added, and is then `lewis` that knows them: `up` checks robot
/// files against them and starts their services (as `<that binary> service NAME`), `replay`
/// and `demo` re-simulate them.
#[must_use]
pub fn main_with(registry: ServiceRegistry) -> ExitCode {
    let cli = Cli::parse();
    match run(cli, registry) {
        Ok(code) => code,
        Err(err) => {
            #[allow(clippy::print_stderr)]
            {
                eprintln!("error: {}", error_text(&err));
            }
            ExitCode::from(2)
        }
    }
}

/// Runs the parsed command with the service kinds of `registry` and returns the process
/// exit code.
///
/// # Errors
/// When the command cannot run; [`main_with`] prints the error chain and exits with 2.
pub fn run(cli: Cli, registry: ServiceRegistry) -> anyhow::Result<ExitCode> {
    // A service started by `lewis up` says as much as `lewis up` was asked to.
    let verbosity = match (cli.verbose, cli.quiet) {
        (0, false) => Verbosity::inherited().unwrap_or_default(),
        (verbose, quiet) => Verbosity::from_flags(verbose, quiet),
    };
    if matches!(
        cli.command,
        Command::Up(_)
            | Command::Service(_)
            | Command::App(_)
            | Command::Demo(_)
            | Command::Record(_)
            | Command::StressPublish(_)
    ) {
        lewis_runtime::logs::init(verbosity);
    }
    match cli.command {
        Command::Idl(command) => idl::run(command),
        Command::Info(args) => info::run(&args),
        Command::Seq(command) => seq::run(command),
        Command::Record(args) => record::run(&args),
        Command::Recover(args) => recover::run(&args),
        Command::Import(command) => import::run(command),
        Command::Export(command) => export::run(command),
        Command::Play(args) => play::run(&args),
        Command::Replay(args) => replay::run(&args, &registry),
        Command::Test(args) => suite::run(&args, &registry),
        Command::Up(args) => up::run(&args, &registry),
        Command::App(args) => app::run(&args),
        Command::Demo(args) => demo::run(&args, &registry),
        Command::Service(args) => service::run(&args, &registry),
        Command::Status(args) => status::run(&args),
        #[cfg(feature = "viewer")]
        Command::View(args) => view::run(&args),
        Command::Fault(args) => fault::run(&args),
        Command::FakeDevice(args) => fake_device::run(&args),
        Command::Tune(command) => tune::run(command),
        Command::StressPublish(args) => stress::run(&args),
        Command::Bench(command) => bench::run(&command, registry),
        Command::World(command) => world::run(&command),
    }
}
