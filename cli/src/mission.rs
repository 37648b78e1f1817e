//! `lewis up ROBOT.toml --script MISSION.seq`: the broker, the services and the sequencer
//! together, until the mission ends.
//!
//! The mission runs on a thread of `lewis up` beside the broker. It waits until the broker
//! answers (so the services it starts on demand can be asked for), then runs the script as
//! `lewis seq run` does: every program with `LEWIS_NAMESPACE` set to the robot's namespace
//! (so a program that is a `lewis` client finds the broker), every record published on
//! `/lewis/sequencer` (so the recorder of `lewis up` keeps it), the supervisor asked on the
//! page or the terminal. When the mission ends, the thread sends SIGTERM to its own process,
//! which stops the broker and the services as Ctrl-C would; `lewis up` then exits with 0 if
//! the mission reached `stop`, 1 if it failed. Ctrl-C, SIGTERM and `--duration` end the
//! mission too (aborted, so exit 1).

use std::os::fd::AsFd;
use std::path::PathBuf;
use std::process::ExitCode;
use std::thread::JoinHandle;
use std::time::{Duration, Instant};

use anyhow::Context as _;
use clap::Args;
use lewis_interfaces::msg::BrokerStatus;
use lewis_runtime::client::call_blocking;
use lewis_runtime::ipc::{Ipc, Namespace};
use lewis_runtime::names;
use lewis_sequencer::live::{Command, ControlReceiver, Controller, SignalForwarder};
use lewis_sequencer::{Outcome, control_channel};

use crate::seq::{MissionArgs, execute, load_mission, report};

/// How long the mission waits for the broker to answer before it gives up.
const BROKER_READY_TIMEOUT: Duration = Duration::from_secs(30);

/// How long one question to the broker may take while waiting for it.
const BROKER_CALL_TIMEOUT: Duration = Duration::from_secs(1);

/// Between two questions to a broker that is not there yet (nothing announces it).
const BROKER_RETRY: Duration = Duration::from_millis(20);

/// The mission options of `lewis up`.
#[derive(Debug, Clone, Args)]
pub struct ScriptArgs {
    /// Run this mission script once the broker is up; `lewis up` ends with the mission: exit
    /// 0 when it reaches `stop`, 1 when it fails.
    #[arg(long, value_name = "MISSION.seq")]
    pub script: Option<PathBuf>,
    /// How the supervisor is asked and where the records go.
    #[command(flatten)]
    pub how: MissionArgs,
}

/// A mission running beside the broker.
#[derive(Debug)]
pub struct MissionRun {
    thread: JoinHandle<anyhow::Result<Outcome>>,
    controller: Controller,
    /// Kept until the thread is joined: its SIGTERM at the end always meets a handler, and
    /// Ctrl-C reaches the mission.
    _signals: SignalForwarder,
}

/// Checks the script, if one was given, and starts its mission on a thread that first
/// waits for the broker. Call before the broker runs.
///
/// # Errors
/// When the script has errors or the thread cannot start.
pub fn start(args: &ScriptArgs, namespace: &Namespace) -> anyhow::Result<Option<MissionRun>> {
    let Some(script) = args.script.clone() else {
        return Ok(None);
    };
    let mission = load_mission(&script)?;
    let (controller, control) = control_channel().context("cannot set up the sequencer")?;
    let signals = SignalForwarder::start(controller.clone())
        .context("cannot catch Ctrl-C to stop the mission cleanly")?;
    let how = args.how.clone();
    let namespace = namespace.clone();
    let thread_controller = controller.clone();
    let thread = std::thread::Builder::new()
        .name("lewis-mission".into())
        .spawn(move || {
            let outcome = match wait_for_broker(&namespace, &control) {
                Ok(()) => execute(
                    &script,
                    mission,
                    &how,
                    false,
                    &namespace,
                    &thread_controller,
                    &control,
                ),
                Err(reason) => Ok(Outcome::Aborted { reason }),
            };
            // The broker and the services go when the mission does.
            let _ = nix::sys::signal::kill(nix::unistd::Pid::this(), nix::sys::signal::SIGTERM);
            outcome
        })
        .context("cannot start the mission thread")?;
    Ok(Some(MissionRun {
        thread,
        controller,
        _signals: signals,
    }))
}

impl MissionRun {
    /// Ends the mission if it still runs (the broker has stopped), waits for it and returns
    /// the exit code: 0 when it reached `stop`.
    ///
    /// # Errors
    /// When the mission could not run (process supervision, the supervisor's page).
    pub fn finish(self) -> anyhow::Result<ExitCode> {
        // Queued and never read when the mission is already over.
        self.controller.interrupt("lewis up ended");
        let outcome = self
            .thread
            .join()
            .map_err(|_| anyhow::anyhow!("the mission thread panicked"))??;
        report(&outcome)
    }
}

/// Waits until the broker of `namespace` answers, or a command (Ctrl-C, the end of `lewis
/// up`) arrives, or [`BROKER_READY_TIMEOUT`] passes; `Err` says why the mission cannot run.
fn wait_for_broker(namespace: &Namespace, control: &ControlReceiver) -> Result<(), String> {
    let ipc = Ipc::open(namespace, &format!("lewis-mission-{}", std::process::id()))
        .map_err(|e| format!("cannot reach the broker: {e}"))?;
    let mut broker = ipc
        .command_client(names::BROKER_COMMAND, &names::broker_command_config())
        .map_err(|e| format!("cannot reach the broker: {e}"))?;
    let deadline = Instant::now() + BROKER_READY_TIMEOUT;
    loop {
        if call_blocking(&mut broker, &BrokerStatus::default(), BROKER_CALL_TIMEOUT).is_ok() {
            return Ok(());
        }
        if Instant::now() >= deadline {
            return Err(format!(
                "the broker of namespace `{namespace}` did not answer within {} s",
                BROKER_READY_TIMEOUT.as_secs()
            ));
        }
        // Nothing announces the broker: ask again shortly, but wake at once for a command.
        let mut fds = [nix::poll::PollFd::new(
            control.as_fd(),
            nix::poll::PollFlags::POLLIN,
        )];
        let timeout =
            nix::poll::PollTimeout::try_from(BROKER_RETRY).unwrap_or(nix::poll::PollTimeout::MAX);
        let _ = nix::poll::poll(&mut fds, timeout);
        if let Some(command) = control.drain().into_iter().next() {
            return Err(match command {
                Command::Interrupt(reason) => format!("interrupted ({reason}) before it started"),
                Command::Stop | Command::Choose(_) => {
                    "stopped by the supervisor before it started".to_owned()
                }
            });
        }
    }
}
