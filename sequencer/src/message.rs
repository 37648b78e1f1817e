//! A [`Record`] as the `Sequencer` interface's publication, and back: what travels on
//! `/lewis/sequencer` and what the recorder stores.
//!
//! The header carries the record's number (`seq` is the number plus 1, as every channel
//! counts from 1) and time (`publish_time_ns`); the fields say what happened, one flat
//! message for every kind of record (see `interfaces/idl/Sequencer.xml`). The mapping is
//! exact: [`from_message`] of [`to_message`] gives the record back.

use std::collections::BTreeMap;
use std::path::PathBuf;

use lewis_interfaces::msg::{
    Header, Sequencer as SequencerMessage, SequencerEntry, SequencerKind, SequencerSupervision,
};

use crate::fsm::{Decision, Event, Supervision};
use crate::record::{Entry, Record};

/// The provider named in the header of the sequencer's publications.
pub const PROVIDER: &str = "lewis-sequencer";

/// A publication that is not a record this sequencer can read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum MessageError {
    /// The header's sequence number is 0: channels count from 1.
    #[error("a Sequencer message with header seq 0: records are numbered from 1")]
    NoSeq,
    /// The `entry` field names no kind of record.
    #[error(
        "record {seq}: unknown entry `{entry}`; expected mission_started, observed, refused, decided or program_started (a newer sequencer?)"
    )]
    UnknownEntry {
        /// The record's number.
        seq: u64,
        /// The entry given.
        entry: String,
    },
    /// The `kind` field names no event or decision.
    #[error("record {seq}: unknown {what} kind `{kind}` (a newer sequencer?)")]
    UnknownKind {
        /// The record's number.
        seq: u64,
        /// `event`, `decision` or `supervision`.
        what: &'static str,
        /// The kind given.
        kind: String,
    },
    /// The environment's names and values differ in number.
    #[error("record {seq}: {names} environment names but {values} values")]
    Environment {
        /// The record's number.
        seq: u64,
        /// How many names.
        names: usize,
        /// How many values.
        values: usize,
    },
}

/// The publication of `record`.
#[must_use]
pub fn to_message(record: &Record) -> SequencerMessage {
    let mut m = SequencerMessage {
        header: Header {
            provider: PROVIDER.to_owned(),
            seq: record.seq.saturating_add(1),
            publish_time_ns: record.time_ns,
            inputs: Vec::new(),
        },
        ..SequencerMessage::default()
    };
    let entry = match &record.entry {
        Entry::MissionStarted {
            script,
            states,
            use_gui,
            supervision,
        } => {
            m.program = script.to_string_lossy().into_owned();
            set_states(&mut m, states);
            m.use_gui = *use_gui;
            m.supervision = supervision
                .map(|s| supervision_word(s).as_str())
                .unwrap_or_default()
                .to_owned();
            SequencerEntry::MissionStarted
        }
        Entry::Observed { event } => {
            put_event(&mut m, event);
            SequencerEntry::Observed
        }
        Entry::Refused { event, error } => {
            put_event(&mut m, event);
            m.error.clone_from(error);
            SequencerEntry::Refused
        }
        Entry::Decided { decision } => {
            put_decision(&mut m, decision);
            SequencerEntry::Decided
        }
        Entry::ProgramStarted {
            state,
            attempt,
            pid,
        } => {
            m.state.clone_from(state);
            m.attempt = *attempt;
            m.pid = *pid;
            SequencerEntry::ProgramStarted
        }
    };
    m.entry = entry.into();
    m
}

fn count(len: usize) -> i32 {
    i32::try_from(len).unwrap_or(i32::MAX)
}

fn set_states(m: &mut SequencerMessage, states: &[String]) {
    m.state_count = count(states.len());
    m.states = states.to_vec();
}

fn put_event(m: &mut SequencerMessage, event: &Event) {
    let kind = match event {
        Event::Exited { code } => {
            m.code = *code;
            SequencerKind::Exited
        }
        Event::Signalled { signal } => {
            m.code = *signal;
            SequencerKind::Signalled
        }
        Event::TimedOut => SequencerKind::TimedOut,
        Event::SpawnFailed { error } => {
            m.reason.clone_from(error);
            SequencerKind::SpawnFailed
        }
        Event::SupervisorChose { state } => {
            m.state.clone_from(state);
            SequencerKind::SupervisorChose
        }
        Event::SupervisorStopped => SequencerKind::SupervisorStopped,
        Event::Interrupted { reason } => {
            m.reason.clone_from(reason);
            SequencerKind::Interrupted
        }
    };
    m.kind = kind.into();
}

fn put_decision(m: &mut SequencerMessage, decision: &Decision) {
    m.reason = decision.reason().to_owned();
    let kind = match decision {
        Decision::Run {
            state,
            program,
            args,
            env,
            timeout_ns,
            attempt,
            ..
        } => {
            m.state.clone_from(state);
            m.program = program.to_string_lossy().into_owned();
            m.arg_count = count(args.len());
            m.args.clone_from(args);
            m.env_count = count(env.len());
            m.env_names = env.keys().cloned().collect();
            m.env_values = env.values().cloned().collect();
            m.has_timeout = timeout_ns.is_some();
            m.timeout_ns = timeout_ns.unwrap_or(0);
            m.attempt = *attempt;
            SequencerKind::Run
        }
        Decision::Restart { state, attempt, .. } => {
            m.state.clone_from(state);
            m.attempt = *attempt;
            SequencerKind::Restart
        }
        Decision::EnterRecovery { from, .. } => {
            m.state.clone_from(from);
            SequencerKind::EnterRecovery
        }
        Decision::AskSupervisor {
            choices, suggested, ..
        } => {
            set_states(m, choices);
            m.suggested = suggested.clone().unwrap_or_default();
            SequencerKind::AskSupervisor
        }
        Decision::Resume { state, .. } => {
            m.state.clone_from(state);
            SequencerKind::Resume
        }
        Decision::Transition { from, to, code, .. } => {
            m.state.clone_from(from);
            m.to.clone_from(to);
            m.code = *code;
            SequencerKind::Transition
        }
        Decision::Finished { .. } => SequencerKind::Finished,
        Decision::Aborted { .. } => SequencerKind::Aborted,
    };
    m.kind = kind.into();
}

/// The record a publication carries.
///
/// # Errors
/// When the header's number is 0, or the entry or kind is unknown.
pub fn from_message(m: &SequencerMessage) -> Result<Record, MessageError> {
    let seq = m.header.seq.checked_sub(1).ok_or(MessageError::NoSeq)?;
    let Some(entry) = SequencerEntry::parse(&m.entry) else {
        return Err(MessageError::UnknownEntry {
            seq,
            entry: m.entry.clone(),
        });
    };
    let entry = match entry {
        SequencerEntry::MissionStarted => Entry::MissionStarted {
            script: PathBuf::from(&m.program),
            states: m.states.clone(),
            use_gui: m.use_gui,
            supervision: supervision_of(seq, &m.supervision)?,
        },
        SequencerEntry::Observed => Entry::Observed {
            event: event_of(seq, m)?,
        },
        SequencerEntry::Refused => Entry::Refused {
            event: event_of(seq, m)?,
            error: m.error.clone(),
        },
        SequencerEntry::Decided => Entry::Decided {
            decision: decision_of(seq, m)?,
        },
        SequencerEntry::ProgramStarted => Entry::ProgramStarted {
            state: m.state.clone(),
            attempt: m.attempt,
            pid: m.pid,
        },
    };
    Ok(Record {
        seq,
        time_ns: m.header.publish_time_ns,
        entry,
    })
}

fn supervision_word(supervision: Supervision) -> SequencerSupervision {
    match supervision {
        Supervision::Page => SequencerSupervision::Page,
        Supervision::Terminal => SequencerSupervision::Terminal,
        Supervision::Unattended => SequencerSupervision::Unattended,
    }
}

fn supervision_of(seq: u64, name: &str) -> Result<Option<Supervision>, MessageError> {
    if name.is_empty() {
        return Ok(None);
    }
    Ok(Some(match SequencerSupervision::parse(name) {
        Some(SequencerSupervision::Page) => Supervision::Page,
        Some(SequencerSupervision::Terminal) => Supervision::Terminal,
        Some(SequencerSupervision::Unattended) => Supervision::Unattended,
        None => return Err(unknown_kind(seq, "supervision", name)),
    }))
}

/// The error for a kind that names no `what` (`event`, `decision`).
fn unknown_kind(seq: u64, what: &'static str, kind: &str) -> MessageError {
    MessageError::UnknownKind {
        seq,
        what,
        kind: kind.to_owned(),
    }
}

fn event_of(seq: u64, m: &SequencerMessage) -> Result<Event, MessageError> {
    Ok(match SequencerKind::parse(&m.kind) {
        Some(SequencerKind::Exited) => Event::Exited { code: m.code },
        Some(SequencerKind::Signalled) => Event::Signalled { signal: m.code },
        Some(SequencerKind::TimedOut) => Event::TimedOut,
        Some(SequencerKind::SpawnFailed) => Event::SpawnFailed {
            error: m.reason.clone(),
        },
        Some(SequencerKind::SupervisorChose) => Event::SupervisorChose {
            state: m.state.clone(),
        },
        Some(SequencerKind::SupervisorStopped) => Event::SupervisorStopped,
        Some(SequencerKind::Interrupted) => Event::Interrupted {
            reason: m.reason.clone(),
        },
        _ => return Err(unknown_kind(seq, "event", &m.kind)),
    })
}

fn decision_of(seq: u64, m: &SequencerMessage) -> Result<Decision, MessageError> {
    let reason = m.reason.clone();
    Ok(match SequencerKind::parse(&m.kind) {
        Some(SequencerKind::Run) => {
            if m.env_names.len() != m.env_values.len() {
                return Err(MessageError::Environment {
                    seq,
                    names: m.env_names.len(),
                    values: m.env_values.len(),
                });
            }
            let env: BTreeMap<String, String> = m
                .env_names
                .iter()
                .cloned()
                .zip(m.env_values.iter().cloned())
                .collect();
            Decision::Run {
                state: m.state.clone(),
                program: PathBuf::from(&m.program),
                args: m.args.clone(),
                env,
                timeout_ns: m.has_timeout.then_some(m.timeout_ns),
                attempt: m.attempt,
                reason,
            }
        }
        Some(SequencerKind::Restart) => Decision::Restart {
            state: m.state.clone(),
            attempt: m.attempt,
            reason,
        },
        Some(SequencerKind::EnterRecovery) => Decision::EnterRecovery {
            from: m.state.clone(),
            reason,
        },
        Some(SequencerKind::AskSupervisor) => Decision::AskSupervisor {
            choices: m.states.clone(),
            suggested: (!m.suggested.is_empty()).then(|| m.suggested.clone()),
            reason,
        },
        Some(SequencerKind::Resume) => Decision::Resume {
            state: m.state.clone(),
            reason,
        },
        Some(SequencerKind::Transition) => Decision::Transition {
            from: m.state.clone(),
            to: m.to.clone(),
            code: m.code,
            reason,
        },
        Some(SequencerKind::Finished) => Decision::Finished { reason },
        Some(SequencerKind::Aborted) => Decision::Aborted { reason },
        _ => return Err(unknown_kind(seq, "decision", &m.kind)),
    })
}
