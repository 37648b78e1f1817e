//! `lewis seq ...`: mission scripts.

use std::io::Write;
use std::net::{IpAddr, Ipv4Addr, SocketAddr};
use std::path::{Path, PathBuf};
use std::process::ExitCode;

use clap::{Args, Subcommand};
use lewis_replay::mission_replay::replay_mission;
use lewis_runtime::ipc::Namespace;
use lewis_sequencer::session::{MissionReport, SessionOptions, load_mission, run_session};

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
    let namespace = Namespace::from_arg(args.namespace.as_deref())?;
    let outcome = run_session(&args.script, mission, &args.how.options(true), &namespace)?;
    Ok(report(&outcome))
}

impl MissionArgs {
    /// The session options these arguments ask for; `echo` prints the decisions and the
    /// programs' lines.
    pub(crate) fn options(&self, echo: bool) -> SessionOptions {
        SessionOptions {
            no_gui: self.no_gui,
            gui_addr: SocketAddr::new(self.gui_bind, self.gui_port),
            events: self.events.clone(),
            open_page: false,
            echo,
            unattended: false,
        }
    }
}

/// Says how the mission ended and its verdict; the exit code: 0 when it succeeded (it
/// reached `stop` other than through recovery), 1 otherwise.
pub(crate) fn report(mission: &MissionReport) -> ExitCode {
    let _ = writeln!(std::io::stdout(), "{mission}");
    if mission.succeeded() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    }
}

fn replay(args: &ReplayArgs) -> anyhow::Result<ExitCode> {
    let replayed = replay_mission(&args.recording, args.script.as_deref(), args.mission)?;
    if let Some(cut) = &replayed.cut {
        writeln!(
            std::io::stderr(),
            "warning: {} is cut short ({cut}); replaying the {} records before the cut",
            replayed.recording.display(),
            replayed.records
        )?;
    }
    writeln!(std::io::stdout(), "{replayed}")?;
    Ok(if replayed.identical() {
        ExitCode::SUCCESS
    } else {
        ExitCode::FAILURE
    })
}
