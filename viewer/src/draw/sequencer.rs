//! The sequencer's records (`/lewis/sequencer`): every record as a line of the text log
//! `events/sequencer` (the mission's start, the programs' exits and crashes, transitions,
//! restarts, recovery, requests for help, the supervisor's choices, the end), and the
//! mission's current state as the state lane `status/sequencer`.
//!
//! The record layout is the `Sequencer` interface's (`interfaces/idl/Sequencer.xml`); the
//! viewer reads its fields and does not depend on the sequencer crate.

use std::collections::BTreeMap;

use lewis_interfaces::msg::{Sequencer, SequencerEntry, SequencerKind};
use rerun::TextLog;

use super::Side;
use super::lanes::{ASKING, STOP};
use crate::ViewError;
use crate::rows::{ChunkSink, Rows, Stamp};

/// What the text log and the lane remember per side (recorded, re-simulated).
#[derive(Debug, Default)]
pub(super) struct SequencerState {
    /// The state whose program runs, for the events that do not name it.
    running: BTreeMap<Side, String>,
    /// The lane's last value.
    lane: BTreeMap<Side, String>,
}

impl SequencerState {
    /// The lane's value now on `side` (the mission's state), when a record set it.
    pub(super) fn current(&self, side: Side) -> Option<&str> {
        self.lane.get(&side).map(String::as_str)
    }

    /// Draws one record.
    pub(super) fn record(
        &mut self,
        rows: &mut Rows,
        sink: &mut dyn ChunkSink,
        side: Side,
        stamp: Stamp,
        m: &Sequencer,
    ) -> Result<(), ViewError> {
        if m.entry == SequencerEntry::Decided && m.kind == SequencerKind::Run {
            self.running.insert(side, m.state.clone());
        }
        let running = self.running.get(&side).map_or("", String::as_str);
        let (text, level) = line(m, running);
        rows.log(
            sink,
            &side.entity("events", &["sequencer"]),
            stamp,
            &TextLog::new(text.clone()).with_level(level),
            text.len() + 32,
        )?;
        let Some(lane) = lane(m) else {
            return Ok(());
        };
        if self.lane.get(&side) == Some(&lane) {
            return Ok(());
        }
        self.lane.insert(side, lane.clone());
        rows.lane(sink, &side.entity("status", &["sequencer"]), stamp, &lane)
    }
}

/// The lane's value after a record, when the record changes where the mission is.
pub(crate) fn lane(m: &Sequencer) -> Option<String> {
    if m.entry != SequencerEntry::Decided {
        return None;
    }
    match SequencerKind::parse(&m.kind)? {
        SequencerKind::Run => Some(m.state.clone()),
        SequencerKind::AskSupervisor => Some(ASKING.to_owned()),
        SequencerKind::Finished => Some(STOP.to_owned()),
        SequencerKind::Aborted => Some(SequencerKind::Aborted.as_str().to_owned()),
        _ => None,
    }
}

/// The text of a record and its level; `running` is the state whose program ran last.
fn line(m: &Sequencer, running: &str) -> (String, &'static str) {
    let why = if m.reason.is_empty() {
        String::new()
    } else {
        format!(": {}", m.reason)
    };
    let Some(entry) = SequencerEntry::parse(&m.entry) else {
        return (format!("{} {} {}{why}", m.entry, m.kind, m.state), "INFO");
    };
    match entry {
        SequencerEntry::MissionStarted => {
            let supervision = if m.supervision.is_empty() {
                String::new()
            } else {
                format!("; the supervisor: {}", m.supervision)
            };
            (
                format!(
                    "mission {} started: states {}{supervision}",
                    m.program,
                    m.states.join(", ")
                ),
                "INFO",
            )
        }
        SequencerEntry::Observed => event(m, running),
        SequencerEntry::Refused => (
            format!("refused {}: {}", event(m, running).0, m.error),
            "WARN",
        ),
        SequencerEntry::Decided => decision(m, &why),
        SequencerEntry::ProgramStarted => (
            format!("started {} attempt {} (pid {})", m.state, m.attempt, m.pid),
            "DEBUG",
        ),
    }
}

fn event(m: &Sequencer, running: &str) -> (String, &'static str) {
    match SequencerKind::parse(&m.kind) {
        Some(SequencerKind::Exited) => (format!("{running} exited with code {}", m.code), "INFO"),
        Some(SequencerKind::Signalled) => {
            (format!("{running} was killed by signal {}", m.code), "WARN")
        }
        Some(SequencerKind::TimedOut) => (format!("{running} ran past its timeout"), "WARN"),
        Some(SequencerKind::SpawnFailed) => {
            (format!("{running} could not start: {}", m.reason), "WARN")
        }
        Some(SequencerKind::SupervisorChose) => {
            (format!("the supervisor chose {}", m.state), "INFO")
        }
        Some(SequencerKind::SupervisorStopped) => {
            ("the supervisor stopped the mission".to_owned(), "WARN")
        }
        Some(SequencerKind::Interrupted) => (format!("interrupted: {}", m.reason), "WARN"),
        _ => (format!("event {}", m.kind), "INFO"),
    }
}

fn decision(m: &Sequencer, why: &str) -> (String, &'static str) {
    match SequencerKind::parse(&m.kind) {
        Some(SequencerKind::Run) => {
            let mut text = format!("run {} attempt {}: {}", m.state, m.attempt, m.program);
            for arg in &m.args {
                text.push_str(&format!(" {arg:?}"));
            }
            (text, "DEBUG")
        }
        Some(SequencerKind::Transition) => (
            format!(
                "transition {} -> {} on exit code {}{why}",
                m.state, m.to, m.code
            ),
            "INFO",
        ),
        Some(SequencerKind::Restart) => (
            format!("restart {} attempt {}{why}", m.state, m.attempt),
            "WARN",
        ),
        Some(SequencerKind::EnterRecovery) => (format!("recovery from {}{why}", m.state), "ERROR"),
        Some(SequencerKind::AskSupervisor) => {
            let suggested = if m.suggested.is_empty() {
                String::new()
            } else {
                format!(", suggested {}", m.suggested)
            };
            (
                format!(
                    "help: the supervisor is asked where to resume ({} or stop{suggested}){why}",
                    m.states.join(", ")
                ),
                "WARN",
            )
        }
        Some(SequencerKind::Resume) => (format!("resume at {}{why}", m.state), "INFO"),
        Some(SequencerKind::Finished) => (format!("mission finished{why}"), "INFO"),
        Some(SequencerKind::Aborted) => (format!("mission aborted{why}"), "ERROR"),
        _ => (format!("decision {} {}{why}", m.kind, m.state), "INFO"),
    }
}
