//! `lewis seq ...`: mission scripts.

use std::collections::BTreeMap;
use std::fs::File;
use std::io::{BufReader, IsTerminal, Write};
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};
use std::process::ExitCode;
use std::sync::mpsc;

use anyhow::{Context, bail};
use clap::{Args, Subcommand};
use lewis_runtime::ipc::{NAMESPACE_ENV, Namespace};
use lewis_sequencer::gui::GuiServer;
use lewis_sequencer::live::{
    ControlReceiver, Controller, LogLine, RunOptions, SignalForwarder, Stream, control_channel,
    run_mission,
};
use lewis_sequencer::record::{Entry, JsonLinesSink, Record, RecordSink, Tee};
use lewis_sequencer::replay::{Recording, compare, read_json_lines, split_missions};
use lewis_sequencer::resolve::{ProgramResolver, SystemResolver, TrustingResolver};
use lewis_sequencer::{
    FileSystem, Mission, Outcome, Publisher, Supervision, TerminalChooser, check_with,
};

/// `lewis seq ...`
#[derive(Debug, Subcommand)]
pub enum SeqCommand {
    /// Check a mission script: syntax, undefined or unreachable states, programs.
    Check {
        /// The script.
        script: PathBuf,
    },
    /// Run a mission: each state's program in turn, restarts, recovery, and the supervisor's
    /// page (with `use gui`); every record is published on /lewis/sequencer. Exits with 0
    /// when the mission reaches `stop`, 1 when it aborts, 2 when it cannot run.
    Run(RunArgs),
    /// Replay a recorded mission on a script's state machine and show the first place where
    /// it decides differently. Exits with 0 when identical, 1 when different.
    Replay(ReplayArgs),
}

/// `lewis seq run`
#[derive(Debug, Args)]
pub struct RunArgs {
    /// The mission script.
    pub script: PathBuf,
    /// The IPC namespace of /lewis/sequencer and of the programs (default:
    /// `LEWIS_NAMESPACE`, else `default`).
    #[arg(long)]
    pub namespace: Option<String>,
    /// How the supervisor is asked and where the records go.
    #[command(flatten)]
    pub how: MissionArgs,
}

/// How a mission runs, for `lewis seq run` and `lewis up --script`.
#[derive(Debug, Clone, Args)]
pub struct MissionArgs {
    /// Do not serve the supervisor's page even with `use gui`: ask on the terminal when the
    /// standard input is one. Without a page and a terminal (a service, CI), nobody is
    /// asked: the recovery state's actions apply.
    #[arg(long)]
    pub no_gui: bool,
    /// The supervisor page's port (0 picks a free one).
    #[arg(long, default_value_t = 8042)]
    pub gui_port: u16,
    /// The supervisor page's address.
    #[arg(long, default_value_t = IpAddr::V4(Ipv4Addr::LOCALHOST))]
    pub gui_bind: IpAddr,
    /// Also write every record (event, decision, program start) to this file, as JSON
    /// lines.
    #[arg(long, value_name = "FILE")]
    pub events: Option<PathBuf>,
}

/// `lewis seq replay`
#[derive(Debug, Args)]
pub struct ReplayArgs {
    /// The recorded mission: an MCAP recording (its /lewis/sequencer channel) or the JSON
    /// lines of `lewis seq run --events`.
    pub recording: PathBuf,
    /// The script to replay (the recorded one when omitted).
    pub script: Option<PathBuf>,
    /// Which mission of the recording, from 1, when it holds several.
    #[arg(long, value_name = "N")]
    pub mission: Option<usize>,
}

pub fn run(command: SeqCommand) -> anyhow::Result<ExitCode> {
    match command {
        SeqCommand::Check { script } => check(&script),
        SeqCommand::Run(args) => run_script(&args),
        SeqCommand::Replay(args) => replay(&args),
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
    let mission = load_mission(&args.script)?;
    let namespace = crate::up::namespace(args.namespace.as_deref())?;
    let (controller, control) = control_channel().context("cannot set up the sequencer")?;
    let signals = SignalForwarder::start(controller.clone())
        .context("cannot catch Ctrl-C to stop the mission cleanly")?;
    let outcome = execute(
        &args.script,
        mission,
        &args.how,
        true,
        &namespace,
        &controller,
        &control,
    );
    drop(signals);
    report(&outcome?)
}

/// Checks the script at `path` (its warnings go to stderr) and returns its mission.
pub(crate) fn load_mission(path: &Path) -> anyhow::Result<Mission> {
    match lewis_sequencer::check_file(path) {
        Ok(checked) => {
            if !checked.warnings.is_empty() {
                writeln!(std::io::stderr(), "{}", checked.warnings)?;
            }
            Ok(checked.mission)
        }
        Err(diagnostics) => bail!("{diagnostics}\n{}: the script has errors", path.display()),
    }
}

/// Runs `mission` (from `script`) to its end: the programs in `namespace` (their
/// `LEWIS_NAMESPACE`), every record published on /lewis/sequencer there and written to
/// `--events`; the supervisor asked on the page, on the terminal, or nobody
/// ([`Supervision::decide`]). With `echo`, the decisions
/// and the programs' lines (`[state] text`) are printed too; without, they go to the logs
/// only (`lewis up`, whose logs already show them). Commands come from `control` (the
/// caller catches the signals).
pub(crate) fn execute(
    script: &Path,
    mission: Mission,
    how: &MissionArgs,
    echo: bool,
    namespace: &Namespace,
    controller: &Controller,
    control: &ControlReceiver,
) -> anyhow::Result<Outcome> {
    let mut events = match &how.events {
        Some(path) => Some(JsonLinesSink::create(path)?),
        None => None,
    };
    let publisher = match Publisher::start(namespace) {
        Ok(started) => Some(started),
        Err(e) => {
            tracing::warn!("the mission is not published, so not recorded: {e}");
            None
        }
    };
    let supervision = Supervision::decide(
        mission.use_gui(),
        how.no_gui,
        std::io::stdin().is_terminal(),
    );
    if echo {
        // `lewis up` has the driver's log line; `lewis seq run` logs nothing else.
        let line = match supervision {
            Supervision::Unattended => {
                "seq: nobody can answer (no supervisor's page, and the standard input is not a \
                 terminal): after recovery the recovery state's actions apply"
            }
            Supervision::Terminal => "seq: the supervisor is asked on this terminal after recovery",
            Supervision::Page => "",
        };
        if !line.is_empty() {
            writeln!(std::io::stderr(), "{line}")?;
        }
    }
    let gui = if supervision == Supervision::Page {
        let gui = GuiServer::start(
            SocketAddr::new(how.gui_bind, how.gui_port),
            &mission,
            controller.clone(),
        )?;
        writeln!(std::io::stdout(), "supervisor's page: {}", gui.url())?;
        Some(gui)
    } else {
        None
    };
    let terminal = if supervision == Supervision::Terminal {
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
    let lines = echo.then_some(lines);
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

    let (publisher, published) = publisher.unzip();
    let mut tee = Tee::new();
    if echo {
        tee = tee.with(Console);
    }
    if let Some(published) = published {
        tee = tee.with(published);
    }
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
        log_lines: lines,
        env: BTreeMap::from([(NAMESPACE_ENV.to_owned(), namespace.as_str().to_owned())]),
        supervision,
        ..RunOptions::new(std::path::absolute(script)?)
    };
    let outcome = run_mission(mission, options, control, &mut tee);
    drop(tee);
    // The supervisor is gone with its output threads: every line has been sent.
    let _ = printer.join();
    if let Some(publisher) = publisher {
        let report = publisher.finish();
        if report.failed > 0 || report.discarded > 0 {
            tracing::warn!(
                "{} of the mission's records were not published and {} deliveries were dropped on /lewis/sequencer",
                report.failed,
                report.discarded
            );
        }
    }
    if let Some(gui) = gui {
        gui.shutdown();
    }
    if let (Some(events), Some(path)) = (events, &how.events) {
        events
            .finish()
            .with_context(|| format!("cannot write the events file {}", path.display()))?;
    }
    Ok(outcome?)
}

/// Says how the mission ended; the exit code: 0 when it reached `stop`, 1 otherwise.
pub(crate) fn report(outcome: &Outcome) -> anyhow::Result<ExitCode> {
    let mut out = std::io::stdout().lock();
    match outcome {
        Outcome::Finished { reason } => {
            writeln!(out, "mission finished: {reason}")?;
            Ok(ExitCode::SUCCESS)
        }
        Outcome::Aborted { reason } => {
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

fn replay(args: &ReplayArgs) -> anyhow::Result<ExitCode> {
    let path = &args.recording;
    let mcap = lewis_replay::mission_log::is_mcap(path)
        .with_context(|| format!("cannot read the recording {}", path.display()))?;
    let records = if mcap {
        let found = lewis_replay::mission_log::read_mcap(path)?;
        if let Some(cut) = &found.cut {
            writeln!(
                std::io::stderr(),
                "warning: {} is cut short ({cut}); replaying the {} records before the cut",
                path.display(),
                found.records.len()
            )?;
        }
        found.records
    } else {
        let file = File::open(path)
            .with_context(|| format!("cannot open the events file {}", path.display()))?;
        read_json_lines(BufReader::new(file)).with_context(|| format!("{}", path.display()))?
    };
    let missions = split_missions(&records);
    let chosen = match (args.mission, missions.len()) {
        (None, 0 | 1) => missions.first().copied().unwrap_or(&[]),
        (None, count) => bail!(
            "{} holds {count} missions; choose one with --mission 1..{count}",
            path.display()
        ),
        (Some(n), count) => match n.checked_sub(1).and_then(|i| missions.get(i)) {
            Some(mission) => mission,
            None => bail!(
                "--mission {n}: {} holds {count} missions, numbered from 1",
                path.display()
            ),
        },
    };
    let recording =
        Recording::from_records(chosen).with_context(|| format!("{}", path.display()))?;
    let script = args.script.as_deref().unwrap_or(&recording.script);
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
                path.display(),
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
                path.display(),
                comparison.identical_decisions,
                script.display()
            )?;
            Ok(ExitCode::FAILURE)
        }
    }
}
