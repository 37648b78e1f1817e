//! The FSM core: events in (a program exited, crashed, timed out; the supervisor chose),
//! decisions out (run, restart, recover, ask, transition, finish). No I/O and no clock, so
//! the live driver and the replay of a recording decide identically.
//!
//! Whether anyone can answer a question ([`Supervision`]) is given to the core at the start
//! by the driver (which knows whether a page is served or a terminal is attached) and is
//! recorded, so that a replay decides as the live run did.
//!
//! Every decision that starts a program is a [`Decision::Run`], preceded by the decision
//! that explains it ([`Decision::Transition`], [`Decision::Restart`],
//! [`Decision::EnterRecovery`], [`Decision::Resume`]); the driver runs the programs and
//! records all of them.

use std::collections::BTreeMap;
use std::fmt;
use std::path::PathBuf;

use serde::{Deserialize, Serialize};

use crate::mission::{Mission, MissionState, Target};
use lewis_stdx::format_duration_ns;

/// Who answers when the sequencer asks where to resume (after recovery, or when recovery
/// itself failed), decided once by the driver before the mission starts.
///
/// Serialised in snake case: `"page"`, `"terminal"`, `"unattended"`.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
#[serde(rename_all = "snake_case")]
pub enum Supervision {
    /// The supervisor's page (`use gui`, without `--no-gui`).
    Page,
    /// The terminal the sequencer runs on (its standard input is a terminal).
    Terminal,
    /// Nobody can answer (no page, and the standard input is not a terminal: a service, a
    /// CI job): the recovery state's own actions apply, and a failed recovery aborts.
    Unattended,
}

impl Supervision {
    /// Whether someone can be asked.
    #[must_use]
    pub fn is_attended(self) -> bool {
        !matches!(self, Self::Unattended)
    }

    /// Who answers for a mission: the page when the script says `use gui` and the page is
    /// not turned off (`--no-gui`); else the terminal when the standard input is one; else
    /// nobody. Reading answers from a pipe or `/dev/null` would turn a closed input into an
    /// aborted mission, so a run under a service manager or in CI is unattended.
    #[must_use]
    pub fn decide(use_gui: bool, no_gui: bool, stdin_is_terminal: bool) -> Self {
        if use_gui && !no_gui {
            Self::Page
        } else if stdin_is_terminal {
            Self::Terminal
        } else {
            Self::Unattended
        }
    }

    /// The supervision of a run recorded before it was recorded: the sequencer then asked
    /// only with `use gui` (on the page, or the terminal with `--no-gui`).
    #[must_use]
    pub fn before_recorded(use_gui: bool) -> Self {
        if use_gui {
            Self::Page
        } else {
            Self::Unattended
        }
    }
}

impl fmt::Display for Supervision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Page => "the supervisor's page",
            Self::Terminal => "the terminal",
            Self::Unattended => "nobody (unattended)",
        })
    }
}

/// What happened, as the driver reports it.
///
/// Serialised (JSON, MCAP) with a `kind` field in snake case: `{"kind":"exited","code":0}`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Event {
    /// The running program exited with this code.
    Exited {
        /// The exit code.
        code: i32,
    },
    /// The running program was killed by this signal: a crash.
    Signalled {
        /// The signal number.
        signal: i32,
    },
    /// The running program outlived its state's timeout and was stopped: a crash.
    TimedOut,
    /// The program could not be started (the driver's error message): a crash.
    SpawnFailed {
        /// Why.
        error: String,
    },
    /// The supervisor chose the state to resume from (`stop` ends the mission).
    SupervisorChose {
        /// The state's name.
        state: String,
    },
    /// The supervisor stopped the mission: while being asked, the mission finishes; while a
    /// program runs, it aborts (the driver stops the program).
    SupervisorStopped,
    /// The sequencer itself was told to stop (Ctrl-C, SIGTERM, its terminal closed): the
    /// mission aborts whatever it was doing (the driver stops the program).
    Interrupted {
        /// By what, for the record (`SIGINT`).
        reason: String,
    },
}

impl fmt::Display for Event {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Exited { code } => write!(f, "exit code {code}"),
            Self::Signalled { signal } => write!(f, "signal {signal}"),
            Self::TimedOut => f.write_str("timeout"),
            Self::SpawnFailed { error } => write!(f, "failure to start ({error})"),
            Self::SupervisorChose { state } => write!(f, "the supervisor's choice of `{state}`"),
            Self::SupervisorStopped => f.write_str("the supervisor's stop"),
            Self::Interrupted { reason } => write!(f, "an interruption ({reason})"),
        }
    }
}

/// What the sequencer decided; each carries a reason for logs and the recording.
///
/// Serialised with a `kind` field in snake case: `{"kind":"transition","from":"door",...}`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "kind", rename_all = "snake_case", deny_unknown_fields)]
pub enum Decision {
    /// Start the state's program.
    Run {
        /// The state.
        state: String,
        /// The program to execute.
        program: PathBuf,
        /// Its arguments.
        args: Vec<String>,
        /// Variables to add to its environment.
        env: BTreeMap<String, String>,
        /// Stop it and report [`Event::TimedOut`] after this long.
        timeout_ns: Option<i64>,
        /// Which run of this visit, from 1 (2 is the first restart).
        attempt: u32,
        /// Why.
        reason: String,
    },
    /// The state's program crashed and is run again.
    Restart {
        /// The state.
        state: String,
        /// The attempt about to start, from 2.
        attempt: u32,
        /// Why.
        reason: String,
    },
    /// A state failed; the recovery state runs next.
    EnterRecovery {
        /// The state that failed.
        from: String,
        /// Why.
        reason: String,
    },
    /// Wait for the supervisor to choose a state ([`Event::SupervisorChose`]) or stop.
    AskSupervisor {
        /// The states that may be chosen, in script order; `stop` is always possible too.
        choices: Vec<String>,
        /// What the script would do (the recovery state's listed target), if anything.
        suggested: Option<String>,
        /// Why.
        reason: String,
    },
    /// The supervisor's choice is taken: the mission resumes at `state`.
    Resume {
        /// The chosen state.
        state: String,
        /// Why.
        reason: String,
    },
    /// A listed exit code leads from one state to the next (`stop` included).
    Transition {
        /// The state that exited.
        from: String,
        /// The next state, or `stop`.
        to: String,
        /// The exit code.
        code: i32,
        /// Why.
        reason: String,
    },
    /// The mission reached `stop`.
    Finished {
        /// Why.
        reason: String,
    },
    /// The mission ended without reaching `stop`.
    Aborted {
        /// Why.
        reason: String,
    },
}

impl Decision {
    /// Why the decision was taken.
    #[must_use]
    pub fn reason(&self) -> &str {
        match self {
            Self::Run { reason, .. }
            | Self::Restart { reason, .. }
            | Self::EnterRecovery { reason, .. }
            | Self::AskSupervisor { reason, .. }
            | Self::Resume { reason, .. }
            | Self::Transition { reason, .. }
            | Self::Finished { reason }
            | Self::Aborted { reason } => reason,
        }
    }
}

impl Decision {
    /// The decision with its reason emptied: what was decided, not how it is explained, so
    /// a replay is not told apart by a reworded message or a changed restart count alone.
    #[must_use]
    pub fn without_reason(&self) -> Self {
        let mut decision = self.clone();
        match &mut decision {
            Self::Run { reason, .. }
            | Self::Restart { reason, .. }
            | Self::EnterRecovery { reason, .. }
            | Self::AskSupervisor { reason, .. }
            | Self::Resume { reason, .. }
            | Self::Transition { reason, .. }
            | Self::Finished { reason }
            | Self::Aborted { reason } => reason.clear(),
        }
        decision
    }

    /// The decision on one line without its reason (`transition door -> sign on 0`).
    #[must_use]
    pub fn summary(&self) -> String {
        struct Summary<'d>(&'d Decision);
        impl fmt::Display for Summary<'_> {
            fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
                self.0.write_summary(f)
            }
        }
        Summary(self).to_string()
    }

    fn write_summary(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Run {
                state,
                program,
                args,
                timeout_ns,
                attempt,
                ..
            } => {
                write!(f, "run {state} attempt {attempt}: {}", program.display())?;
                for arg in args {
                    write!(f, " {arg:?}")?;
                }
                if let Some(timeout_ns) = timeout_ns {
                    write!(f, " (timeout {})", format_duration_ns(*timeout_ns))?;
                }
            }
            Self::Restart { state, attempt, .. } => write!(f, "restart {state} attempt {attempt}")?,
            Self::EnterRecovery { from, .. } => write!(f, "recover from {from}")?,
            Self::AskSupervisor {
                choices, suggested, ..
            } => {
                write!(f, "ask the supervisor: {} or stop", choices.join(", "))?;
                if let Some(suggested) = suggested {
                    write!(f, " (suggested {suggested})")?;
                }
            }
            Self::Resume { state, .. } => write!(f, "resume at {state}")?,
            Self::Transition { from, to, code, .. } => {
                write!(f, "transition {from} -> {to} on {code}")?;
            }
            Self::Finished { .. } => f.write_str("finished")?,
            Self::Aborted { .. } => f.write_str("aborted")?,
        }
        Ok(())
    }
}

impl fmt::Display for Decision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        self.write_summary(f)?;
        write!(f, " | {}", self.reason())
    }
}

/// An event that does not fit the sequencer's phase; the sequencer is left unchanged.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum EventError {
    /// A program event while no program runs, or a choice while none is asked for.
    #[error("{event} is unexpected while {phase}")]
    Unexpected {
        /// The event.
        event: String,
        /// What the sequencer was doing.
        phase: String,
    },
    /// The supervisor chose a state the mission does not have.
    #[error("the supervisor chose `{state}`, which is not a state of the mission")]
    UnknownState {
        /// The name chosen.
        state: String,
    },
}

/// Where the sequencer is.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
enum Phase {
    /// The state's program is running this attempt.
    Running { state: usize, attempt: u32 },
    /// Waiting for the supervisor.
    Asking,
    /// The mission reached `stop`.
    Finished,
    /// The mission ended early.
    Aborted,
}

/// How a run ended badly.
enum Failure {
    /// A crash: restarted up to the limit.
    Crash(String),
    /// An exit code the state does not list: straight to recovery.
    Unlisted(i32),
}

/// The mission's state machine.
#[derive(Debug, Clone)]
pub struct Sequencer {
    mission: Mission,
    supervision: Supervision,
    phase: Phase,
}

/// Whether an unlisted exit code means the program crashed rather than chose an outcome:
/// Rust's panic code, and the shell's "killed by signal" range.
fn is_abnormal_exit(code: i32) -> bool {
    code == 101 || !(0..128).contains(&code)
}

impl Sequencer {
    /// Starts `mission`, with `supervision` saying whether anyone can be asked: the
    /// sequencer and its first decisions (running the start state).
    #[must_use]
    pub fn start(mission: Mission, supervision: Supervision) -> (Self, Vec<Decision>) {
        let start = mission.start_index();
        let mut sequencer = Self {
            mission,
            supervision,
            phase: Phase::Finished,
        };
        let reason = format!("the mission starts at `{}`", sequencer.name(start));
        let decisions = vec![sequencer.run(start, 1, reason)];
        (sequencer, decisions)
    }

    /// The mission being run.
    #[must_use]
    pub fn mission(&self) -> &Mission {
        &self.mission
    }

    /// Who answers the sequencer's questions.
    #[must_use]
    pub fn supervision(&self) -> Supervision {
        self.supervision
    }

    /// The state whose program is running, and its attempt, if one is.
    #[must_use]
    pub fn running(&self) -> Option<(&str, u32)> {
        match self.phase {
            Phase::Running { state, attempt } => Some((self.name(state), attempt)),
            _ => None,
        }
    }

    /// Whether the sequencer waits for the supervisor.
    #[must_use]
    pub fn is_asking(&self) -> bool {
        self.phase == Phase::Asking
    }

    /// Whether the mission is over (finished or aborted).
    #[must_use]
    pub fn is_over(&self) -> bool {
        matches!(self.phase, Phase::Finished | Phase::Aborted)
    }

    /// Decides what follows `event`.
    ///
    /// # Errors
    /// When the event does not fit the current phase (a program event while none runs, a
    /// choice while none is asked for, anything after the end, an unknown chosen state);
    /// the sequencer is then unchanged.
    pub fn handle(&mut self, event: &Event) -> Result<Vec<Decision>, EventError> {
        match (self.phase, event) {
            (Phase::Running { state, attempt }, Event::Exited { code }) => {
                Ok(self.exited(state, attempt, *code))
            }
            (Phase::Running { state, attempt }, Event::Signalled { signal }) => Ok(self.failed(
                state,
                attempt,
                &Failure::Crash(format!("was killed by signal {signal}")),
            )),
            (Phase::Running { state, attempt }, Event::TimedOut) => {
                let what = self.mission.states()[state].timeout_ns.map_or_else(
                    || "timed out".to_owned(),
                    |ns| format!("ran past its {} timeout", format_duration_ns(ns)),
                );
                Ok(self.failed(state, attempt, &Failure::Crash(what)))
            }
            (Phase::Running { state, attempt }, Event::SpawnFailed { error }) => Ok(self.failed(
                state,
                attempt,
                &Failure::Crash(format!("could not start ({error})")),
            )),
            (Phase::Running { state, .. }, Event::SupervisorStopped) => {
                self.phase = Phase::Aborted;
                Ok(vec![Decision::Aborted {
                    reason: format!(
                        "the supervisor stopped the mission while `{}` was running",
                        self.name(state)
                    ),
                }])
            }
            (Phase::Running { state, .. }, Event::Interrupted { reason }) => {
                self.phase = Phase::Aborted;
                Ok(vec![Decision::Aborted {
                    reason: format!(
                        "the sequencer was interrupted ({reason}) while `{}` was running",
                        self.name(state)
                    ),
                }])
            }
            (Phase::Asking, Event::Interrupted { reason }) => {
                self.phase = Phase::Aborted;
                Ok(vec![Decision::Aborted {
                    reason: format!(
                        "the sequencer was interrupted ({reason}) while the supervisor was asked"
                    ),
                }])
            }
            (Phase::Asking, Event::SupervisorStopped) => {
                Ok(self.finish("the supervisor chose to stop".into()))
            }
            (Phase::Asking, Event::SupervisorChose { state }) if state == "stop" => {
                Ok(self.finish("the supervisor chose to stop".into()))
            }
            (Phase::Asking, Event::SupervisorChose { state }) => {
                let index =
                    self.mission
                        .index_of(state)
                        .ok_or_else(|| EventError::UnknownState {
                            state: state.clone(),
                        })?;
                Ok(vec![
                    Decision::Resume {
                        state: state.clone(),
                        reason: format!("the supervisor chose `{state}`"),
                    },
                    self.run(index, 1, format!("the supervisor chose `{state}`")),
                ])
            }
            (phase, event) => Err(EventError::Unexpected {
                event: event.to_string(),
                phase: self.describe(phase),
            }),
        }
    }

    fn describe(&self, phase: Phase) -> String {
        match phase {
            Phase::Running { state, .. } => format!("`{}` runs", self.name(state)),
            Phase::Asking => "the supervisor is asked".into(),
            Phase::Finished => "the mission is finished".into(),
            Phase::Aborted => "the mission is aborted".into(),
        }
    }

    fn name(&self, index: usize) -> &str {
        &self.mission.states()[index].name
    }

    fn state(&self, index: usize) -> &MissionState {
        &self.mission.states()[index]
    }

    fn run(&mut self, index: usize, attempt: u32, reason: String) -> Decision {
        self.phase = Phase::Running {
            state: index,
            attempt,
        };
        let state = self.state(index);
        Decision::Run {
            state: state.name.clone(),
            program: state.program.clone(),
            args: state.args.clone(),
            env: state.env.clone(),
            timeout_ns: state.timeout_ns,
            attempt,
            reason,
        }
    }

    fn finish(&mut self, reason: String) -> Vec<Decision> {
        self.phase = Phase::Finished;
        vec![Decision::Finished { reason }]
    }

    fn exited(&mut self, index: usize, attempt: u32, code: i32) -> Vec<Decision> {
        let state = self.state(index);
        let Some(target) = state.actions.get(&code).cloned() else {
            let failure = if is_abnormal_exit(code) {
                Failure::Crash(format!(
                    "exited with code {code}, which the script does not list"
                ))
            } else {
                Failure::Unlisted(code)
            };
            return self.failed(index, attempt, &failure);
        };
        let from = state.name.clone();
        let is_recovery = self.mission.recovery_index() == Some(index);
        if is_recovery && self.supervision.is_attended() {
            return self.ask(
                Some(target.name().to_owned()),
                format!("recovery `{from}` is over (exit code {code})"),
            );
        }
        let mut reason = format!(
            "`{from}` exited with code {code}, which leads to `{}`",
            target.name()
        );
        if is_recovery {
            reason.push_str("; nobody can be asked where to resume (unattended)");
        }
        let transition = Decision::Transition {
            from: from.clone(),
            to: target.name().to_owned(),
            code,
            reason,
        };
        match target {
            Target::Stop => {
                let mut decisions = vec![transition];
                decisions.extend(self.finish(format!("`{from}` led to `stop`")));
                decisions
            }
            Target::State(name) => {
                // The checker guarantees every target; a missing one would be a bug here.
                let next = self.mission.index_of(&name).unwrap_or(index);
                let run = self.run(
                    next,
                    1,
                    format!("transition from `{from}` on exit code {code}"),
                );
                vec![transition, run]
            }
        }
    }

    fn failed(&mut self, index: usize, attempt: u32, failure: &Failure) -> Vec<Decision> {
        let state = self.state(index);
        let name = state.name.clone();
        let limit = state.restart_limit;
        let restarts_done = attempt.saturating_sub(1);
        let why = match failure {
            Failure::Crash(what) if restarts_done < limit => {
                let reason = format!("`{name}` {what}; restart {} of {limit}", restarts_done + 1);
                let restart = Decision::Restart {
                    state: name.clone(),
                    attempt: attempt + 1,
                    reason: reason.clone(),
                };
                let run = self.run(index, attempt + 1, reason);
                return vec![restart, run];
            }
            Failure::Crash(what) if limit == 0 => {
                format!("`{name}` {what}, with no restart allowed")
            }
            Failure::Crash(what) => {
                let plural = if limit == 1 { "" } else { "s" };
                format!("`{name}` {what} after {limit} restart{plural}")
            }
            Failure::Unlisted(code) => {
                format!("`{name}` exited with code {code}, which the script does not list")
            }
        };
        match self.mission.recovery_index() {
            Some(recovery) if recovery == index => self.give_up(format!("recovery failed: {why}")),
            Some(recovery) => {
                let recovery_name = self.name(recovery).to_owned();
                let enter = Decision::EnterRecovery {
                    from: name,
                    reason: why.clone(),
                };
                let run = self.run(recovery, 1, format!("recovery `{recovery_name}`: {why}"));
                vec![enter, run]
            }
            None => self.give_up(format!("{why}, and the script has no recovery state")),
        }
    }

    /// The end of automatic handling: ask the supervisor when someone can answer, else
    /// abort.
    fn give_up(&mut self, why: String) -> Vec<Decision> {
        if self.supervision.is_attended() {
            self.ask(None, why)
        } else {
            self.phase = Phase::Aborted;
            vec![Decision::Aborted {
                reason: format!("{why}; nobody can be asked where to resume (unattended)"),
            }]
        }
    }

    fn ask(&mut self, suggested: Option<String>, reason: String) -> Vec<Decision> {
        self.phase = Phase::Asking;
        vec![Decision::AskSupervisor {
            choices: self
                .mission
                .states()
                .iter()
                .map(|s| s.name.clone())
                .collect(),
            suggested,
            reason,
        }]
    }
}
