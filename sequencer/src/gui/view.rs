//! What the supervisor's page shows, built from the records alone: the mission's diagram,
//! where it is, what was decided, and the question when the supervisor is asked. Pure, so
//! the page's content is tested without a browser.

use std::collections::VecDeque;

use serde::Serialize;

use crate::fsm::Decision;
use crate::mission::Mission;
use crate::record::{Entry, Record};

/// How many history lines the page gets; older ones are dropped from the page (the
/// recording keeps them).
pub const HISTORY_LINES: usize = 200;

/// The mission's diagram: states and their transitions.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Diagram {
    /// The states, in script order.
    pub states: Vec<DiagramState>,
    /// Whether the supervisor is asked after recovery.
    pub use_gui: bool,
}

/// One box of the diagram.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct DiagramState {
    /// The state's name.
    pub name: String,
    /// The program's file name (without its folder).
    pub program: String,
    /// Whether the mission starts here.
    pub start: bool,
    /// Whether this is the recovery state.
    pub recovery: bool,
    /// The restart limit.
    pub restart_limit: u32,
    /// Its transitions, by exit code.
    pub actions: Vec<DiagramAction>,
}

/// One arrow of the diagram.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct DiagramAction {
    /// The exit code.
    pub code: i32,
    /// The target state, or `stop`.
    pub to: String,
}

impl Diagram {
    /// The diagram of `mission`.
    #[must_use]
    pub fn of(mission: &Mission) -> Self {
        let start = mission.start().name.as_str();
        let recovery = mission.recovery().map(|s| s.name.as_str());
        let states = mission
            .states()
            .iter()
            .map(|state| DiagramState {
                name: state.name.clone(),
                program: state.program.file_name().map_or_else(
                    || state.program.display().to_string(),
                    |f| f.to_string_lossy().into_owned(),
                ),
                start: state.name == start,
                recovery: Some(state.name.as_str()) == recovery,
                restart_limit: state.restart_limit,
                actions: state
                    .actions
                    .iter()
                    .map(|(code, target)| DiagramAction {
                        code: *code,
                        to: target.name().to_owned(),
                    })
                    .collect(),
            })
            .collect();
        Self {
            states,
            use_gui: mission.use_gui(),
        }
    }
}

/// Where the mission is.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize)]
#[serde(rename_all = "snake_case")]
pub enum Phase {
    /// Not started yet.
    Starting,
    /// A program runs.
    Running,
    /// Waiting for the supervisor.
    Asking,
    /// Reached `stop`.
    Finished,
    /// Ended early.
    Aborted,
}

/// The program running now.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Current {
    /// Its state.
    pub state: String,
    /// Which run of the visit, from 1.
    pub attempt: u32,
    /// Its process id, once started.
    pub pid: Option<u32>,
}

/// The question to the supervisor.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct Question {
    /// The states to choose from (`stop` is always offered too).
    pub choices: Vec<String>,
    /// What the script would do, if anything.
    pub suggested: Option<String>,
    /// Why the supervisor is asked.
    pub reason: String,
}

/// One line of the history.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct HistoryLine {
    /// The record's number.
    pub seq: u64,
    /// When (ns since the Unix epoch).
    pub time_ns: i64,
    /// What kind of line (`start`, `transition`, `restart`, `recovery`, `ask`, `resume`,
    /// `finished`, `aborted`, `refused`), for its colour.
    pub kind: &'static str,
    /// What happened, short.
    pub text: String,
    /// Why.
    pub reason: String,
}

/// Everything the page shows, sent whole on every change.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct View {
    /// Increases with every change.
    pub version: u64,
    /// The diagram.
    pub diagram: Diagram,
    /// Where the mission is.
    pub phase: Phase,
    /// The program running now.
    pub current: Option<Current>,
    /// The question, while the supervisor is asked.
    pub question: Option<Question>,
    /// Why the mission ended, once it has.
    pub outcome: Option<String>,
    /// The states visited, in order of first visit (for the diagram).
    pub visited: Vec<String>,
    /// The most recent history lines, oldest first.
    pub history: VecDeque<HistoryLine>,
    /// Whether the first program has been run (its run is the history's first line; later
    /// runs follow a line that explains them).
    #[serde(skip)]
    started: bool,
}

impl View {
    /// The view of `mission` before it starts.
    #[must_use]
    pub fn new(mission: &Mission) -> Self {
        Self {
            version: 0,
            diagram: Diagram::of(mission),
            phase: Phase::Starting,
            current: None,
            question: None,
            outcome: None,
            visited: Vec::new(),
            history: VecDeque::new(),
            started: false,
        }
    }

    /// Takes one record into account.
    pub fn apply(&mut self, record: &Record) {
        self.version += 1;
        match &record.entry {
            Entry::MissionStarted { .. } | Entry::Observed { .. } => {}
            Entry::ProgramStarted { state, pid, .. } => {
                if let Some(current) = self.current.as_mut().filter(|c| c.state == *state) {
                    current.pid = Some(*pid);
                }
            }
            Entry::Refused { event, error } => {
                self.push(record, "refused", format!("refused {event}"), error.clone());
            }
            Entry::Decided { decision } => self.decided(record, decision),
        }
    }

    fn decided(&mut self, record: &Record, decision: &Decision) {
        let reason = decision.reason().to_owned();
        let kind = match decision {
            Decision::Run { state, attempt, .. } => {
                self.phase = Phase::Running;
                self.question = None;
                self.current = Some(Current {
                    state: state.clone(),
                    attempt: *attempt,
                    pid: None,
                });
                if !self.visited.contains(state) {
                    self.visited.push(state.clone());
                }
                if self.started {
                    // The decision that explains a run is in the history already.
                    return;
                }
                self.started = true;
                let text = format!("start at {state}");
                self.push(record, "start", text, reason);
                return;
            }
            Decision::Restart { .. } => "restart",
            Decision::EnterRecovery { .. } => "recovery",
            Decision::AskSupervisor {
                choices, suggested, ..
            } => {
                self.phase = Phase::Asking;
                self.current = None;
                self.question = Some(Question {
                    choices: choices.clone(),
                    suggested: suggested.clone(),
                    reason: reason.clone(),
                });
                // The choices are on the buttons; the history says only that help was asked.
                let text = suggested.as_ref().map_or_else(
                    || "ask the supervisor".to_owned(),
                    |s| format!("ask the supervisor (suggested {s})"),
                );
                self.push(record, "ask", text, reason);
                return;
            }
            Decision::Resume { .. } => "resume",
            Decision::Transition { .. } => "transition",
            Decision::Finished { .. } => {
                self.end(Phase::Finished, &reason);
                "finished"
            }
            Decision::Aborted { .. } => {
                self.end(Phase::Aborted, &reason);
                "aborted"
            }
        };
        self.push(record, kind, decision.summary(), reason);
    }

    fn end(&mut self, phase: Phase, reason: &str) {
        self.phase = phase;
        self.current = None;
        self.question = None;
        self.outcome = Some(reason.to_owned());
    }

    fn push(&mut self, record: &Record, kind: &'static str, text: String, reason: String) {
        if self.history.len() == HISTORY_LINES {
            self.history.pop_front();
        }
        self.history.push_back(HistoryLine {
            seq: record.seq,
            time_ns: record.time_ns,
            kind,
            text,
            reason,
        });
    }
}
