//! The sequencer's records (`/lewis/sequencer`): every record as a line of the text log
//! `events/sequencer` (the mission's start, the programs' exits and crashes, transitions,
//! restarts, recovery, requests for help, the supervisor's choices, the end), and the
//! mission's current state as the state lane `status/sequencer`.
//!
//! The record layout is the `Sequencer` interface's (`interfaces/idl/Sequencer.xml`); the
//! viewer reads its fields and does not depend on the sequencer crate.

use std::collections::BTreeMap;

use lewis_interfaces::msg::Sequencer;
use rerun::TextLog;

use super::Side;
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
    /// Draws one record.
    pub(super) fn record(
        &mut self,
        rows: &mut Rows,
        sink: &mut dyn ChunkSink,
        side: Side,
        stamp: Stamp,
        m: &Sequencer,
    ) -> Result<(), ViewError> {
        if m.entry == "decided" && m.kind == "run" {
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
fn lane(m: &Sequencer) -> Option<String> {
    if m.entry != "decided" {
        return None;
    }
    match m.kind.as_str() {
        "run" => Some(m.state.clone()),
        "ask_supervisor" => Some("asking the supervisor".to_owned()),
        "finished" => Some("stop".to_owned()),
        "aborted" => Some("aborted".to_owned()),
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
    match m.entry.as_str() {
        "mission_started" => {
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
        "observed" => event(m, running),
        "refused" => (
            format!("refused {}: {}", event(m, running).0, m.error),
            "WARN",
        ),
        "decided" => decision(m, &why),
        "program_started" => (
            format!("started {} attempt {} (pid {})", m.state, m.attempt, m.pid),
            "DEBUG",
        ),
        other => (format!("{other} {} {}{why}", m.kind, m.state), "INFO"),
    }
}

fn event(m: &Sequencer, running: &str) -> (String, &'static str) {
    match m.kind.as_str() {
        "exited" => (format!("{running} exited with code {}", m.code), "INFO"),
        "signalled" => (format!("{running} was killed by signal {}", m.code), "WARN"),
        "timed_out" => (format!("{running} ran past its timeout"), "WARN"),
        "spawn_failed" => (format!("{running} could not start: {}", m.reason), "WARN"),
        "supervisor_chose" => (format!("the supervisor chose {}", m.state), "INFO"),
        "supervisor_stopped" => ("the supervisor stopped the mission".to_owned(), "WARN"),
        "interrupted" => (format!("interrupted: {}", m.reason), "WARN"),
        other => (format!("event {other}"), "INFO"),
    }
}

fn decision(m: &Sequencer, why: &str) -> (String, &'static str) {
    match m.kind.as_str() {
        "run" => {
            let mut text = format!("run {} attempt {}: {}", m.state, m.attempt, m.program);
            for arg in &m.args {
                text.push_str(&format!(" {arg:?}"));
            }
            (text, "DEBUG")
        }
        "transition" => (
            format!(
                "transition {} -> {} on exit code {}{why}",
                m.state, m.to, m.code
            ),
            "INFO",
        ),
        "restart" => (
            format!("restart {} attempt {}{why}", m.state, m.attempt),
            "WARN",
        ),
        "enter_recovery" => (format!("recovery from {}{why}", m.state), "ERROR"),
        "ask_supervisor" => {
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
        "resume" => (format!("resume at {}{why}", m.state), "INFO"),
        "finished" => (format!("mission finished{why}"), "INFO"),
        "aborted" => (format!("mission aborted{why}"), "ERROR"),
        other => (format!("decision {other} {}{why}", m.state), "INFO"),
    }
}
