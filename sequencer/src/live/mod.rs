//! The live driver: runs a checked mission with real processes.
//!
//! It feeds the pure FSM ([`Sequencer`]) with what happens to the state's program, started
//! through the runtime's process supervision (no shell, its own process group, output
//! forwarded line by line with the state's name), and carries out the decisions. A state's
//! timeout stops the program (SIGTERM, then SIGKILL after the grace period) and counts as a
//! crash. Commands from other threads ([`Controller`]: the supervisor's choice, a stop, an
//! interruption) arrive through an eventfd, so the driver sleeps in one `poll` on its child
//! and its commands, with the timeout as the only deadline.
//!
//! Every event fed to the FSM and every decision is sent, numbered and timed, to a
//! [`RecordSink`].

mod control;
mod signals;

use std::collections::{BTreeMap, VecDeque};
use std::io;
use std::path::PathBuf;
use std::sync::mpsc::SyncSender;
use std::time::{Duration, Instant};

use lewis_runtime::clock::LiveClock;

use lewis_runtime::supervise::{
    ChildSpec, DEFAULT_STOP_GRACE, ExitStatus, SuperviseError, Supervisor, SupervisorEvent,
};
use rustix::event::{PollFd, PollFlags};

pub use control::{Command, ControlReceiver, Controller, control_channel};
/// A program's output line (named after its state) and its stream, from the runtime.
pub use lewis_runtime::supervise::{LogLine, Stream};
pub use signals::SignalForwarder;

use crate::fsm::{Decision, Event, Sequencer, Supervision};
use crate::mission::Mission;
use crate::record::{Entry, Record, RecordSink};

/// How to run a mission.
#[derive(Debug, Clone)]
pub struct RunOptions {
    /// The script the mission came from, for the first record.
    pub script: PathBuf,
    /// Time between SIGTERM and SIGKILL when a program is stopped.
    pub stop_grace: Duration,
    /// Where the programs' output lines go, besides `tracing`; each [`LogLine`] is named after
    /// its state. Lines are dropped (and counted by the supervisor) when the channel is full.
    pub log_lines: Option<SyncSender<LogLine>>,
    /// Variables set for every program before the script's own `env` (which win): what the
    /// caller knows and the script should not have to say, such as `LEWIS_NAMESPACE`.
    pub env: BTreeMap<String, String>,
    /// Who answers the sequencer's questions; the caller serves the page or reads the
    /// terminal (a [`crate::gui::GuiSink`], a [`crate::TerminalChooser`]) and says so here.
    pub supervision: Supervision,
}

impl RunOptions {
    /// Options for the mission of `script`: the default grace, output to `tracing` only,
    /// nobody to ask ([`Supervision::Unattended`]).
    #[must_use]
    pub fn new(script: impl Into<PathBuf>) -> Self {
        Self {
            script: script.into(),
            stop_grace: DEFAULT_STOP_GRACE,
            log_lines: None,
            env: BTreeMap::new(),
            supervision: Supervision::Unattended,
        }
    }
}

/// How a mission ended.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum Outcome {
    /// It reached `stop`.
    Finished {
        /// Why, as the FSM said.
        reason: String,
    },
    /// It ended early.
    Aborted {
        /// Why, as the FSM said.
        reason: String,
    },
}

impl Outcome {
    /// Whether the mission reached `stop`.
    #[must_use]
    pub fn is_finished(&self) -> bool {
        matches!(self, Self::Finished { .. })
    }
}

/// The driver could not go on (its programs are stopped before this is returned).
#[derive(Debug, thiserror::Error)]
pub enum RunError {
    /// Process supervision failed.
    #[error(transparent)]
    Supervise(#[from] SuperviseError),
    /// Waiting for the program and the commands failed.
    #[error("cannot wait for the mission's program and commands: {0}")]
    Poll(#[source] io::Error),
}

/// Runs `mission` until it finishes or aborts, taking commands from `control` and sending
/// every record to `sink`.
///
/// # Errors
/// When process supervision itself fails; a program that cannot start is not an error (it
/// is a crash for the FSM).
pub fn run_mission(
    mission: Mission,
    options: RunOptions,
    control: &ControlReceiver,
    sink: &mut dyn RecordSink,
) -> Result<Outcome, RunError> {
    let supervisor = match options.log_lines.clone() {
        Some(lines) => Supervisor::with_log_sink(lines)?,
        None => Supervisor::new()?,
    };
    let mut driver = Driver {
        supervisor,
        recorder: Recorder {
            sink,
            next_seq: 0,
            clock: LiveClock::new(),
        },
        pending: VecDeque::new(),
        current: None,
        outcome: None,
        stop_grace: options.stop_grace,
        env: options.env,
    };
    match options.supervision {
        Supervision::Unattended => tracing::warn!(
            "nobody can answer the sequencer (no supervisor's page, and the standard input \
             is not a terminal): after recovery the recovery state's actions apply, and a \
             failed recovery aborts the mission"
        ),
        asked => tracing::info!("the supervisor is asked on {asked} after recovery"),
    }
    driver.recorder.emit(Entry::MissionStarted {
        script: options.script,
        states: mission.states().iter().map(|s| s.name.clone()).collect(),
        use_gui: mission.use_gui(),
        supervision: Some(options.supervision),
    });
    let (mut sequencer, decisions) = Sequencer::start(mission, options.supervision);
    for decision in decisions {
        driver.apply(decision);
    }
    let result = driver.run(&mut sequencer, control);
    driver.stop_current();
    for (name, stopped) in driver.supervisor.stop_all() {
        if let Err(e) = stopped {
            tracing::error!(state = %name, "cannot stop the program: {e}");
        }
    }
    result?;
    Ok(driver.outcome.unwrap_or_else(|| Outcome::Aborted {
        reason: "the mission ended without a decision to end it".into(),
    }))
}

/// The program of the current state.
struct Current {
    state: String,
    pid: u32,
    deadline: Option<Instant>,
}

struct Recorder<'s> {
    sink: &'s mut dyn RecordSink,
    next_seq: u64,
    /// The runtime's clock, as every Lewis process reads it: records line up with the
    /// services' publications.
    clock: LiveClock,
}

impl Recorder<'_> {
    fn emit(&mut self, entry: Entry) {
        let record = Record {
            seq: self.next_seq,
            time_ns: self.clock.now_ns(),
            entry,
        };
        self.next_seq += 1;
        self.sink.record(&record);
    }
}

struct Driver<'s> {
    supervisor: Supervisor,
    recorder: Recorder<'s>,
    /// Events for the FSM not yet fed (a failed start, a timeout, a command).
    pending: VecDeque<Event>,
    current: Option<Current>,
    outcome: Option<Outcome>,
    stop_grace: Duration,
    env: BTreeMap<String, String>,
}

impl Driver<'_> {
    fn run(
        &mut self,
        sequencer: &mut Sequencer,
        control: &ControlReceiver,
    ) -> Result<(), RunError> {
        loop {
            while let Some(event) = self.pending.pop_front() {
                self.feed(sequencer, event);
            }
            if sequencer.is_over() {
                return Ok(());
            }
            self.wait(control)?;
            while let Some(event) = self.supervisor.try_event()? {
                self.on_supervisor_event(&event);
            }
            self.check_deadline();
            for command in control.drain() {
                self.on_command(command);
            }
        }
    }

    /// Sleeps until the program exits, a command arrives or the deadline passes.
    fn wait(&self, control: &ControlReceiver) -> Result<(), RunError> {
        let timeout = self
            .current
            .as_ref()
            .and_then(|c| c.deadline)
            .map(|d| d.saturating_duration_since(Instant::now()));
        let timespec = timeout.map(|t| {
            rustix::time::Timespec::try_from(t).unwrap_or(rustix::time::Timespec {
                tv_sec: i64::MAX,
                tv_nsec: 0,
            })
        });
        let mut fds = [
            PollFd::new(&self.supervisor, PollFlags::IN),
            PollFd::new(control, PollFlags::IN),
        ];
        match rustix::event::poll(&mut fds, timespec.as_ref()) {
            Ok(_) | Err(rustix::io::Errno::INTR) => Ok(()),
            Err(e) => Err(RunError::Poll(e.into())),
        }
    }

    fn feed(&mut self, sequencer: &mut Sequencer, event: Event) {
        match sequencer.handle(&event) {
            Ok(decisions) => {
                self.recorder.emit(Entry::Observed { event });
                for decision in decisions {
                    self.apply(decision);
                }
            }
            Err(error) => {
                tracing::warn!("{error}");
                self.recorder.emit(Entry::Refused {
                    event,
                    error: error.to_string(),
                });
            }
        }
    }

    fn apply(&mut self, decision: Decision) {
        tracing::info!("{decision}");
        self.recorder.emit(Entry::Decided {
            decision: decision.clone(),
        });
        match decision {
            Decision::Run {
                state,
                program,
                args,
                env,
                timeout_ns,
                attempt,
                ..
            } => {
                let mut spec = ChildSpec::new(state.clone(), program)
                    .args(args)
                    .stop_grace(self.stop_grace);
                for (key, value) in self.env.iter().chain(&env) {
                    spec = spec.env(key, value);
                }
                match self.supervisor.start(spec) {
                    Ok(pid) => {
                        let deadline = timeout_ns.map(|ns| {
                            Instant::now() + Duration::from_nanos(u64::try_from(ns).unwrap_or(0))
                        });
                        self.recorder.emit(Entry::ProgramStarted {
                            state: state.clone(),
                            attempt,
                            pid,
                        });
                        self.current = Some(Current {
                            state,
                            pid,
                            deadline,
                        });
                    }
                    Err(error) => self.pending.push_back(Event::SpawnFailed {
                        error: error.to_string(),
                    }),
                }
            }
            Decision::Finished { reason } => self.outcome = Some(Outcome::Finished { reason }),
            Decision::Aborted { reason } => self.outcome = Some(Outcome::Aborted { reason }),
            Decision::Restart { .. }
            | Decision::EnterRecovery { .. }
            | Decision::AskSupervisor { .. }
            | Decision::Resume { .. }
            | Decision::Transition { .. } => {}
        }
    }

    fn on_supervisor_event(&mut self, event: &SupervisorEvent) {
        let SupervisorEvent::Exited { pid, status, .. } = event else {
            // Programs are started without automatic restarts: nothing else can happen.
            return;
        };
        if self.current.as_ref().is_none_or(|c| c.pid != *pid) {
            // A program given up on earlier (stuck after SIGKILL) has finally gone.
            return;
        }
        self.current = None;
        self.pending.push_back(match *status {
            ExitStatus::Exited { code } => Event::Exited { code },
            ExitStatus::Signalled { signal, .. } => Event::Signalled { signal },
        });
    }

    fn check_deadline(&mut self) {
        let overdue = self
            .current
            .as_ref()
            .and_then(|c| c.deadline)
            .is_some_and(|d| Instant::now() >= d);
        if overdue {
            self.stop_current();
            self.pending.push_back(Event::TimedOut);
        }
    }

    fn on_command(&mut self, command: Command) {
        match command {
            Command::Choose(state) => self.pending.push_back(Event::SupervisorChose { state }),
            Command::Stop => {
                self.stop_current();
                self.pending.push_back(Event::SupervisorStopped);
            }
            Command::Interrupt(reason) => {
                self.stop_current();
                self.pending.push_back(Event::Interrupted { reason });
            }
        }
    }

    /// Stops the current program, if any: SIGTERM, SIGKILL after the grace period.
    fn stop_current(&mut self) {
        let Some(current) = self.current.take() else {
            return;
        };
        match self.supervisor.stop(&current.state) {
            Ok(status) => tracing::info!(
                state = %current.state, pid = current.pid,
                "program stopped{}", status.map(|s| format!(": {s}")).unwrap_or_default()
            ),
            Err(e) => tracing::error!(state = %current.state, "{e}"),
        }
    }
}
