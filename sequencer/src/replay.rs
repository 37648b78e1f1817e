//! Replaying a recorded mission: the recorded events (exit codes, crashes, timeouts, the
//! supervisor's choices) are fed to the FSM of a script, maybe a changed one, and its
//! decisions are compared with the recorded ones: the regression test for mission scripts.
//!
//! Reading ([`read_json_lines`], `lewis_replay::mission_log::read_mcap`) is kept apart from the comparison
//! ([`Recording::from_records`], [`compare`]), which only sees [`Record`]s.

use std::fmt;
use std::io::BufRead;
use std::path::PathBuf;

use crate::fsm::{Decision, Event, EventError, Sequencer, Supervision};
use crate::mission::Mission;
use crate::record::{Entry, Record};

/// A JSON-lines file of records could not be read.
#[derive(Debug, thiserror::Error)]
pub enum ReadError {
    /// Reading failed.
    #[error("cannot read the events: {0}")]
    Io(#[from] std::io::Error),
    /// A line is not a record.
    #[error("line {line}: not a sequencer record ({error}); is this a `--events` file?")]
    Json {
        /// The line, from 1.
        line: usize,
        /// What the parser said.
        error: serde_json::Error,
    },
}

/// Reads records written by [`JsonLinesSink`](crate::record::JsonLinesSink); blank lines
/// are skipped.
///
/// # Errors
/// On a read error or a line that is not a record.
pub fn read_json_lines(reader: impl BufRead) -> Result<Vec<Record>, ReadError> {
    let mut records = Vec::new();
    for (index, line) in reader.lines().enumerate() {
        let line = line?;
        if line.trim().is_empty() {
            continue;
        }
        let record = serde_json::from_str(&line).map_err(|error| ReadError::Json {
            line: index + 1,
            error,
        })?;
        records.push(record);
    }
    Ok(records)
}

/// Splits the records of a recording that may hold several missions (a robot that ran
/// `lewis seq run` twice while recorded) into one slice per mission, each starting at its
/// [`Entry::MissionStarted`]; records before the first start (a recording begun late) make
/// a slice of their own, which [`Recording::from_records`] then refuses as cut.
#[must_use]
pub fn split_missions(records: &[Record]) -> Vec<&[Record]> {
    let mut starts: Vec<usize> = records
        .iter()
        .enumerate()
        .filter(|(_, r)| matches!(r.entry, Entry::MissionStarted { .. }))
        .map(|(i, _)| i)
        .collect();
    if !records.is_empty() && starts.first() != Some(&0) {
        starts.insert(0, 0);
    }
    starts
        .iter()
        .zip(starts.iter().skip(1).chain([&records.len()]))
        .map(|(&from, &to)| &records[from..to])
        .collect()
}

/// Records that do not make a mission.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RecordingError {
    /// No records at all.
    #[error("the recording holds no sequencer record")]
    Empty,
    /// The first record does not start a mission.
    #[error("record {seq} comes before the mission's start: the recording is cut")]
    NoStart {
        /// The first record's number.
        seq: u64,
    },
    /// A second mission starts in the same recording.
    #[error("record {seq} starts a second mission; replay one mission at a time")]
    SecondMission {
        /// The record's number.
        seq: u64,
    },
}

/// One event of a recording and the decisions recorded after it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Step {
    /// The event, or `None` for the mission's start.
    pub event: Option<Event>,
    /// When it was recorded (ns since the Unix epoch).
    pub time_ns: i64,
    /// The record number of the event (or of the mission's start).
    pub seq: u64,
    /// The decisions that followed, in order.
    pub decisions: Vec<Decision>,
}

/// A recorded mission, as the FSM saw it.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recording {
    /// The script it ran.
    pub script: PathBuf,
    /// Who could answer the sequencer's questions, as recorded (or as the sequencer of
    /// the time decided it, for older records).
    pub supervision: Supervision,
    /// The start, then every accepted event, each with its decisions.
    pub steps: Vec<Step>,
}

impl Recording {
    /// Groups `records` (one mission's, in order) into steps. Refused events and program
    /// starts are not part of the FSM's history and are left out.
    ///
    /// # Errors
    /// When the records are empty, cut before the start, or hold two missions.
    pub fn from_records(records: &[Record]) -> Result<Self, RecordingError> {
        let (first, rest) = records.split_first().ok_or(RecordingError::Empty)?;
        let Entry::MissionStarted {
            script,
            use_gui,
            supervision,
            ..
        } = &first.entry
        else {
            return Err(RecordingError::NoStart { seq: first.seq });
        };
        let mut steps = vec![Step {
            event: None,
            time_ns: first.time_ns,
            seq: first.seq,
            decisions: Vec::new(),
        }];
        for record in rest {
            match &record.entry {
                Entry::MissionStarted { .. } => {
                    return Err(RecordingError::SecondMission { seq: record.seq });
                }
                Entry::Observed { event } => steps.push(Step {
                    event: Some(event.clone()),
                    time_ns: record.time_ns,
                    seq: record.seq,
                    decisions: Vec::new(),
                }),
                Entry::Decided { decision } => {
                    if let Some(step) = steps.last_mut() {
                        step.decisions.push(decision.clone());
                    }
                }
                Entry::Refused { .. } | Entry::ProgramStarted { .. } => {}
            }
        }
        Ok(Self {
            script: script.clone(),
            supervision: supervision.unwrap_or_else(|| Supervision::before_recorded(*use_gui)),
            steps,
        })
    }

    /// How many decisions were recorded.
    #[must_use]
    pub fn decision_count(&self) -> usize {
        self.steps.iter().map(|s| s.decisions.len()).sum()
    }
}

/// Where the script decides differently from the recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Difference {
    /// The step of the recording (0 is the start).
    pub step: usize,
    /// The recorded event that led to it (`None`: the start).
    pub event: Option<Event>,
    /// When that event was recorded (ns since the Unix epoch).
    pub time_ns: i64,
    /// The position of the first differing decision within the step.
    pub index: usize,
    /// The recorded decision there, or `None` if the recording had no more.
    pub recorded: Option<Decision>,
    /// The script's decision there, or why the script refused the event; `None` if it
    /// decided nothing more.
    pub replayed: Option<Result<Decision, EventError>>,
}

impl fmt::Display for Difference {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match &self.event {
            None => write!(f, "at the start")?,
            Some(event) => write!(f, "after event {} ({event})", self.step)?,
        }
        writeln!(f, ", decision {}:", self.index + 1)?;
        match &self.recorded {
            Some(decision) => writeln!(f, "  recorded: {decision}")?,
            None => writeln!(f, "  recorded: nothing more")?,
        }
        match &self.replayed {
            Some(Ok(decision)) => write!(f, "  script:   {decision}"),
            Some(Err(error)) => write!(f, "  script:   refuses the event: {error}"),
            None => write!(f, "  script:   nothing more"),
        }
    }
}

/// What a replay found.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Comparison {
    /// Steps replayed identically.
    pub identical_steps: usize,
    /// Decisions replayed identically.
    pub identical_decisions: usize,
    /// The first difference, if any.
    pub difference: Option<Difference>,
}

/// Feeds the recorded events to `mission`'s FSM, with the recorded supervision, and
/// compares its decisions with the recorded ones, reasons aside
/// ([`Decision::without_reason`]); stops at the first difference.
#[must_use]
pub fn compare(mission: Mission, recording: &Recording) -> Comparison {
    let (mut sequencer, start) = Sequencer::start(mission, recording.supervision);
    let mut comparison = Comparison {
        identical_steps: 0,
        identical_decisions: 0,
        difference: None,
    };
    for (index, step) in recording.steps.iter().enumerate() {
        let replayed = match &step.event {
            None => Ok(start.clone()),
            Some(event) => sequencer.handle(event),
        };
        let difference = match replayed {
            Err(error) => Some((0, Some(Err(error)))),
            Ok(decisions) => first_difference(&step.decisions, &decisions)
                .map(|at| (at, decisions.get(at).cloned().map(Ok))),
        };
        if let Some((at, replayed)) = difference {
            comparison.identical_decisions += at;
            comparison.difference = Some(Difference {
                step: index,
                event: step.event.clone(),
                time_ns: step.time_ns,
                index: at,
                recorded: step.decisions.get(at).cloned(),
                replayed,
            });
            return comparison;
        }
        comparison.identical_steps += 1;
        comparison.identical_decisions += step.decisions.len();
    }
    comparison
}

fn first_difference(recorded: &[Decision], replayed: &[Decision]) -> Option<usize> {
    let same = recorded
        .iter()
        .zip(replayed)
        .take_while(|(a, b)| a.without_reason() == b.without_reason())
        .count();
    (same < recorded.len().max(replayed.len())).then_some(same)
}
