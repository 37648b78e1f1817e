//! What the live driver reports: every event it fed the FSM and every decision it got back,
//! numbered and timed, to a caller-supplied [`RecordSink`].
//!
//! The records are what `/lewis/sequencer` carries ([`crate::publish`], as the `Sequencer`
//! interface, [`crate::message`]) and so what recordings hold, what the GUI shows, and what
//! `lewis seq replay` reads back; [`JsonLinesSink`] also writes them as one JSON object per
//! line (`lewis seq run --events FILE`), for a mission run without a recorder.

use std::fmt;
use std::fs::File;
use std::io::{self, BufWriter, Write};
use std::path::{Path, PathBuf};
use std::sync::mpsc::Sender;

use serde::{Deserialize, Serialize};

use crate::fsm::{Decision, Event, Supervision};

/// One thing the sequencer did or saw, in order.
///
/// As JSON: `{"seq":3,"time_ns":1717000000000000000,"entry":{"type":"decided",
/// "decision":{"kind":"transition","from":"door","to":"sign","code":0,"reason":"..."}}}`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct Record {
    /// The record's position in its mission, from 0, without gaps.
    pub seq: u64,
    /// When, in nanoseconds since the Unix epoch (the wall clock, as MCAP log times).
    pub time_ns: i64,
    /// What.
    pub entry: Entry,
}

/// What a [`Record`] says.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
#[serde(tag = "type", rename_all = "snake_case", deny_unknown_fields)]
pub enum Entry {
    /// The first record of a mission: which script, which states.
    MissionStarted {
        /// The script's path as given to the sequencer.
        script: PathBuf,
        /// The states, in script order.
        states: Vec<String>,
        /// Whether the script says `use gui`.
        use_gui: bool,
        /// Who answered the sequencer's questions; absent in records made before it was
        /// recorded (see [`Supervision::before_recorded`]).
        #[serde(default, skip_serializing_if = "Option::is_none")]
        supervision: Option<Supervision>,
    },
    /// An event the FSM accepted; the decisions it led to follow.
    Observed {
        /// The event.
        event: Event,
    },
    /// An event the FSM refused (a choice while nothing is asked, an unknown state); nothing
    /// changed.
    Refused {
        /// The event.
        event: Event,
        /// Why it was refused.
        error: String,
    },
    /// A decision of the FSM.
    Decided {
        /// The decision.
        decision: Decision,
    },
    /// The driver started a state's program (after a [`Decision::Run`]).
    ProgramStarted {
        /// The state.
        state: String,
        /// Which run of the visit, from 1.
        attempt: u32,
        /// The process id.
        pid: u32,
    },
}

impl fmt::Display for Entry {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::MissionStarted { script, .. } => {
                write!(f, "mission {} started", script.display())
            }
            Self::Observed { event } => write!(f, "event: {event}"),
            Self::Refused { event, error } => write!(f, "refused {event}: {error}"),
            Self::Decided { decision } => write!(f, "{decision}"),
            Self::ProgramStarted {
                state,
                attempt,
                pid,
            } => write!(f, "started {state} attempt {attempt} (pid {pid})"),
        }
    }
}

/// Where the live driver sends its records.
///
/// Called on the driver's thread, in order; an implementation must not block for long (the
/// mission waits). A sink that cannot deliver a record keeps going and reports the failure
/// its own way: losing the record must not stop the robot.
pub trait RecordSink {
    /// Takes one record.
    fn record(&mut self, record: &Record);
}

impl<S: RecordSink + ?Sized> RecordSink for &mut S {
    fn record(&mut self, record: &Record) {
        (**self).record(record);
    }
}

impl<S: RecordSink + ?Sized> RecordSink for Box<S> {
    fn record(&mut self, record: &Record) {
        (**self).record(record);
    }
}

/// Keeps every record (a mission's records are few: a handful per state visited).
impl RecordSink for Vec<Record> {
    fn record(&mut self, record: &Record) {
        self.push(record.clone());
    }
}

/// Sends every record to several sinks, in order. It is `Send`, so the mission can run on
/// a thread of its own.
#[derive(Default)]
pub struct Tee<'a> {
    sinks: Vec<Box<dyn RecordSink + Send + 'a>>,
}

impl<'a> Tee<'a> {
    /// A tee with no sink yet.
    #[must_use]
    pub fn new() -> Self {
        Self { sinks: Vec::new() }
    }

    /// Adds a sink.
    #[must_use]
    pub fn with(mut self, sink: impl RecordSink + Send + 'a) -> Self {
        self.sinks.push(Box::new(sink));
        self
    }
}

impl RecordSink for Tee<'_> {
    fn record(&mut self, record: &Record) {
        for sink in &mut self.sinks {
            sink.record(record);
        }
    }
}

/// Sends records to a channel (for another thread, a test, or the IPC publisher); a
/// receiver that is gone is ignored.
#[derive(Debug, Clone)]
pub struct ChannelSink(pub Sender<Record>);

impl RecordSink for ChannelSink {
    fn record(&mut self, record: &Record) {
        let _ = self.0.send(record.clone());
    }
}

/// Writes records as JSON lines, flushed one by one so a crash loses nothing written.
///
/// The first write error is kept (see [`JsonLinesSink::finish`]) and later records are
/// dropped.
#[derive(Debug)]
pub struct JsonLinesSink<W: Write> {
    out: W,
    error: Option<io::Error>,
}

impl JsonLinesSink<BufWriter<File>> {
    /// Creates (or truncates) the file at `path`.
    ///
    /// # Errors
    /// When the file cannot be created.
    pub fn create(path: &Path) -> io::Result<Self> {
        let file = File::create(path).map_err(|e| {
            io::Error::new(
                e.kind(),
                format!("cannot create the events file {}: {e}", path.display()),
            )
        })?;
        Ok(Self::new(BufWriter::new(file)))
    }
}

impl<W: Write> JsonLinesSink<W> {
    /// Writes to `out`.
    pub fn new(out: W) -> Self {
        Self { out, error: None }
    }

    /// Flushes and hands back the writer, or the first error met.
    ///
    /// # Errors
    /// The first error met while writing or flushing.
    pub fn finish(mut self) -> io::Result<W> {
        if let Some(error) = self.error.take() {
            return Err(error);
        }
        self.out.flush()?;
        Ok(self.out)
    }
}

impl<W: Write> RecordSink for JsonLinesSink<W> {
    fn record(&mut self, record: &Record) {
        if self.error.is_some() {
            return;
        }
        let written = serde_json::to_writer(&mut self.out, record)
            .map_err(io::Error::from)
            .and_then(|()| self.out.write_all(b"\n"))
            .and_then(|()| self.out.flush());
        if let Err(error) = written {
            tracing::error!("cannot write the sequencer's events: {error}; later ones are lost");
            self.error = Some(error);
        }
    }
}
