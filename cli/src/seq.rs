//! `lewis seq ...`: mission scripts.

use std::fs::File;
use std::io::{BufReader, Write};
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::mpsc;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use lewis_sequencer::gui::GuiServer;
use lewis_sequencer::live::{
    LogLine, RunOptions, SignalForwarder, Stream, control_channel, run_mission,
};
use lewis_sequencer::record::{Entry, JsonLinesSink, Record, RecordSink, Tee};
use lewis_sequencer::replay::{Recording, compare, read_json_lines};
use lewis_sequencer::resolve::{ProgramResolver, SystemResolver, TrustingResolver};
use lewis_sequencer::{FileSystem, TerminalChooser, check_with};

/// `lewis seq ...`
#[derive(Debug, Subcommand)]
pub enum SeqCommand {
    /// Check a mission script: syntax, undefined or unreachable states, programs.
    Check {
        /// The script.
        script: PathBuf,
    },
    /// Run a mission: each state's program in turn, restarts, recovery, and the supervisor's
    /// page (with `use gui`). Exits with 0 when the mission reaches `stop`, 1 when it
    /// aborts, 2 when it cannot run.
    Run(RunArgs),
    /// Replay recorded events on a script's state machine and show the first place where it
    /// decides differently. Exits with 0 when identical, 1 when different.
    Replay {
        /// The events, as written by `lewis seq run --events`.
        events: PathBuf,
        /// The script to replay (the recorded one when omitted).
        script: Option<PathBuf>,
    },
}

/// `lewis seq run`
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The mission script.
    pub script: PathBuf,
    /// Ask the supervisor on the terminal instead of the page.
    #[arg(long)]
    pub no_gui: bool,
    /// The supervisor page's port (0 picks a free one).
    #[arg(long, default_value_t = 8042)]
    pub gui_port: u16,
    /// The supervisor page's address.
    #[arg(long, default_value_t = IpAddr::V4(Ipv4Addr::LOCALHOST))]
    pub gui_bind: IpAddr,
    /// Also write every event and decision to this file, as JSON lines.
    #[arg(long, value_name = "FILE")]
    pub events: Option<PathBuf>,
}

pub fn run(command: SeqCommand) -> anyhow::Result<ExitCode> {
    match command {
        SeqCommand::Check { script } => check(&script),
        SeqCommand::Run(args) => run_script(&args),
        SeqCommand::Replay { events, script } => replay(&events, script.as_deref()),
    }
}

fn check(script: &Path) -> anyhow::Result<ExitCode> {
    let mut out = std::io::stdout().lock();
    match lewis_sequencer::check_file(script) {
        Ok(checked) => {
            if !checked.warnings.is_empty() {
                writeln!(out, "{}", checked.warnings)?;
            }
            writeln!(out, "{}: ok", script.display())?;
            Ok(ExitCode::SUCCESS)
        }
        Err(diagnostics) => {
            writeln!(out, "{diagnostics}")?;
            Ok(ExitCode::FAILURE)
        }
    }
}

fn run_script(args: &RunArgs) -> anyhow::Result<ExitCode> {
    let checked = match lewis_sequencer::check_file(&args.script) {
        Ok(checked) => checked,
        Err(diagnostics) => {
            bail!(
                "{diagnostics}\n{}: the script has errors",
                args.script.display()
            )
        }
    };
    if !checked.warnings.is_empty() {
        writeln!(std::io::stderr(), "{}", checked.warnings)?;
    }
    let mission = checked.mission;
    let (controller, control) = control_channel().context("cannot set up the sequencer")?;
    let _signals = SignalForwarder::start(controller.clone())
        .context("cannot catch Ctrl-C to stop the mission cleanly")?;

    let mut events = match &args.events {
        Some(path) => Some(JsonLinesSink::create(path)?),
        None => None,
    };
    let gui = if mission.use_gui() && !args.no_gui {
        let gui = GuiServer::start(
            SocketAddr::new(args.gui_bind, args.gui_port),
            &mission,
            controller.clone(),
        )?;
        writeln!(std::io::stdout(), "supervisor's page: {}", gui.url())?;
        Some(gui)
    } else {
        None
    };
    let terminal = if mission.use_gui() && gui.is_none() {
        let stdin = BufReader::new(std::io::stdin());
        Some(TerminalChooser::start(
            stdin,
            std::io::stderr(),
            controller.clone(),
        )?)
    } else {
        None
    };

    let (lines, incoming) = mpsc::sync_channel(4096);
    let printer = std::thread::Builder::new()
        .name("lewis-seq-output".into())
        .spawn(move || {
            for line in incoming {
                let line: LogLine = line;
                let text = format!("[{}] {}\n", line.name, line.text);
                let _ = match line.stream {
                    Stream::Stdout => std::io::stdout().write_all(text.as_bytes()),
                    Stream::Stderr => std::io::stderr().write_all(text.as_bytes()),
                };
            }
        })?;

    let mut tee = Tee::new().with(Console);
    if let Some(events) = events.as_mut() {
        tee = tee.with(events);
    }
    if let Some(gui) = &gui {
        tee = tee.with(gui.sink());
    }
    if let Some(terminal) = terminal {
        tee = tee.with(terminal);
    }
    let options = RunOptions {
        log_lines: Some(lines),
        ..RunOptions::new(std::path::absolute(&args.script)?)
    };
    let outcome = run_mission(mission, options, &control, &mut tee);
    drop(tee);
    // The supervisor is gone with its output threads: every line has been sent.
    let _ = printer.join();
    if let Some(gui) = gui {
        gui.shutdown();
    }
    if let (Some(events), Some(path)) = (events, &args.events) {
        events
            .finish()
            .with_context(|| format!("cannot write the events file {}", path.display()))?;
    }
    let outcome = outcome?;
    let mut out = std::io::stdout().lock();
    match outcome {
        lewis_sequencer::Outcome::Finished { reason } => {
            writeln!(out, "mission finished: {reason}")?;
            Ok(ExitCode::SUCCESS)
        }
        lewis_sequencer::Outcome::Aborted { reason } => {
            writeln!(out, "mission aborted: {reason}")?;
            Ok(ExitCode::FAILURE)
        }
    }
}

/// Prints the mission's decisions as they are taken.
struct Console;

impl RecordSink for Console {
    fn record(&mut self, record: &Record) {
        let line = match &record.entry {
            Entry::Decided { decision } => format!("seq: {decision}\n"),
            Entry::Refused { event, error } => format!("seq: refused {event}: {error}\n"),
            Entry::MissionStarted { .. }
            | Entry::Observed { .. }
            | Entry::ProgramStarted { .. } => {
                return;
            }
        };
        let _ = std::io::stdout().write_all(line.as_bytes());
    }
}

fn replay(events: &Path, script: Option<&Path>) -> anyhow::Result<ExitCode> {
    let file = File::open(events)
        .with_context(|| format!("cannot open the events file {}", events.display()))?;
    let records =
        read_json_lines(BufReader::new(file)).with_context(|| format!("{}", events.display()))?;
    let recording =
        Recording::from_records(&records).with_context(|| format!("{}", events.display()))?;
    let script = script.unwrap_or(&recording.script);
    // The programs need not be installed where a recording is replayed: those that are
    // resolve as on the robot, the others are taken as written.
    let system = SystemResolver::from_env();
    let resolver = |program: &str, folder: &Path| {
        system
            .resolve(program, folder)
            .or_else(|_| TrustingResolver.resolve(program, folder))
    };
    let checked = match check_with(script, &FileSystem, &resolver) {
        Ok(checked) => checked,
        Err(diagnostics) => bail!("{diagnostics}\n{}: the script has errors", script.display()),
    };
    let comparison = compare(checked.mission, &recording);
    let mut out = std::io::stdout().lock();
    match comparison.difference {
        None => {
            writeln!(
                out,
                "{}: {} events and {} decisions replayed on {}: identical",
                events.display(),
                recording.steps.len() - 1,
                recording.decision_count(),
                script.display()
            )?;
            Ok(ExitCode::SUCCESS)
        }
        Some(difference) => {
            writeln!(
                out,
                "{}: {} decisions identical, then {} decides differently {difference}",
                events.display(),
                comparison.identical_decisions,
                script.display()
            )?;
            Ok(ExitCode::FAILURE)
        }
    }
}
