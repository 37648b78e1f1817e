//! Closing the loop (`--all`): whether a recording can be lived again whole, and what it
//! takes.
//!
//! It can when every source of the robot is simulated (the simulator's devices re-run from
//! the recorded world and seeds: the world then reacts to what the robot does) and, when a
//! mission was recorded, its script can be read and every program it names can run in the
//! harness. Then the mission is started where it started live, the supervisor's recorded
//! answers are kept for its questions, and the faults of the live run (a provider whose
//! process died, as the demo kills the laser) are applied again at their recorded times.
//!
//! When it cannot (a real robot's recording, a CARMEN or ROS 2 import, a script that is
//! gone), it says why and the replay is open loop: the recorded sources are fed as they
//! were.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Broker as BrokerMessage, BrokerAction, Sequencer as SequencerMessage};
use lewis_robot::{Launch, Robot};
use lewis_runtime::names;
use lewis_sequencer::{
    Decision, Entry, Event, FileSystem, Record, Recording as MissionSteps, TrustingResolver,
    check_with, from_message,
};

use crate::fault::{Fault, FaultKind, format_seconds};
use crate::lockstep::{MissionPlan, Programs};
use crate::outcome::LoopKind;
use lewis_recording::Recording;

/// What closing the loop takes, or why it cannot be closed.
#[derive(Debug, Default)]
pub struct Closure {
    /// Whether `--all` asked for the loop to be closed.
    pub asked: bool,
    /// Why the loop stays open when it was asked to close (`None`: closed, if asked).
    pub open_because: Option<String>,
    /// The mission to live again.
    pub mission: Option<MissionPlan>,
    /// The recorded mission's records (for its verdict), whether or not the loop closes.
    pub recorded: Vec<Record>,
    /// Faults of the live run, to apply again.
    pub recorded_faults: Vec<Fault>,
}

impl Closure {
    /// The loop as the report says it.
    #[must_use]
    pub fn loop_kind(&self) -> LoopKind {
        match (&self.open_because, self.asked) {
            (_, false) => LoopKind::Open { because: None },
            (None, true) => LoopKind::Closed,
            (Some(why), true) => LoopKind::Open {
                because: Some(why.clone()),
            },
        }
    }

    /// Whether the loop is closed.
    #[must_use]
    pub fn is_closed(&self) -> bool {
        self.loop_kind() == LoopKind::Closed
    }
}

/// The recorded mission's records, from every file of the run (the last mission when there
/// are several); empty when none was recorded or the files cannot be read for it. Only the
/// chunks that hold `/lewis/sequencer` records are read (through the message indexes).
#[must_use]
pub fn recorded_mission(recording: &Recording) -> Vec<Record> {
    let recorded = recording
        .topics()
        .get(names::SEQUENCER_CHANNEL)
        .is_some_and(|t| t.message_count > 0);
    let Some(messages) = recorded
        .then(|| recording.messages_on(&[names::SEQUENCER_CHANNEL]).ok())
        .flatten()
    else {
        return Vec::new();
    };
    let mut records: Vec<Record> = messages
        .flatten()
        .filter_map(|m| cdr::from_bytes::<SequencerMessage>(&m.data).ok())
        .filter_map(|m| from_message(&m).ok())
        .collect();
    let last = records
        .iter()
        .rposition(|r| matches!(r.entry, Entry::MissionStarted { .. }))
        .unwrap_or(0);
    records.split_off(last)
}

/// Works out whether `recording` of `robot` can be lived again whole.
#[must_use]
pub fn close(
    recording: &Recording,
    robot: &Robot,
    source_kinds: &BTreeSet<String>,
    simulated_kinds: &BTreeSet<String>,
    programs: Option<&dyn Programs>,
) -> Closure {
    let recorded = recorded_mission(recording);
    let mut closure = Closure {
        asked: true,
        recorded,
        ..Closure::default()
    };
    if let Err(why) = sources_simulated(robot, source_kinds, simulated_kinds) {
        closure.open_because = Some(why);
        return closure;
    }
    let history = BrokerHistory::read(recording, robot);
    match mission_plan(&closure.recorded, recording, programs, &history) {
        Ok(plan) => closure.mission = plan,
        Err(why) => {
            closure.open_because = Some(why);
            return closure;
        }
    }
    closure.recorded_faults = history.deaths(recording.start_ns());
    closure
}

/// Every source of the robot is a simulated device, or which are not.
fn sources_simulated(
    robot: &Robot,
    source_kinds: &BTreeSet<String>,
    simulated_kinds: &BTreeSet<String>,
) -> Result<(), String> {
    let real: Vec<String> = robot
        .services
        .iter()
        .filter_map(|spec| {
            let kind = match &spec.launch {
                Launch::Kind(kind) => Some(kind.as_str()),
                Launch::Command(_) => None,
            };
            let source = spec.requires.is_empty() || kind.is_some_and(|k| source_kinds.contains(k));
            let simulated = kind.is_some_and(|k| simulated_kinds.contains(k));
            (source && !simulated).then(|| match kind {
                Some(kind) => format!("{} ({kind})", spec.name),
                None => format!("{} (its own command)", spec.name),
            })
        })
        .collect();
    if real.is_empty() {
        Ok(())
    } else {
        Err(format!(
            "the sources {} are not simulated: what they saw cannot be seen again differently",
            real.join(", ")
        ))
    }
}

/// The recorded mission as the harness runs it: `None` when none was recorded.
fn mission_plan(
    records: &[Record],
    recording: &Recording,
    programs: Option<&dyn Programs>,
    history: &BrokerHistory,
) -> Result<Option<MissionPlan>, String> {
    let (Some(first), Ok(started)) = (records.first(), MissionSteps::from_records(records)) else {
        return Ok(None);
    };
    let Some(programs) = programs else {
        return Err("this binary cannot run the mission's programs".to_owned());
    };
    let path = find_script(&started.script, recording);
    let checked = check_with(&path, &FileSystem, &TrustingResolver).map_err(|d| {
        format!(
            "the recorded mission's script {} cannot be checked: {}",
            path.display(),
            d.to_string().lines().next().unwrap_or_default()
        )
    })?;
    for state in checked.mission.states() {
        programs
            .build(&state.program, &state.args)
            .map_err(|e| format!("state `{}` cannot run here: {e}", state.name))?;
    }
    let recorded_answers = records
        .iter()
        .filter_map(|r| match &r.entry {
            Entry::Observed {
                event: Event::SupervisorChose { state },
            } => Some(state.clone()),
            Entry::Observed {
                event: Event::SupervisorStopped,
            } => Some("stop".to_owned()),
            _ => None,
        })
        .collect();
    Ok(Some(MissionPlan {
        mission: checked.mission,
        supervision: started.supervision,
        script: started.script,
        start_ns: first.time_ns,
        recorded_answers,
        start_delays: start_delays(records, history),
    }))
}

/// How long each recorded run of a program took to come up: from the `run` decision to the
/// broker's first decision about its client (named `<program>-<pid>`).
fn start_delays(records: &[Record], history: &BrokerHistory) -> Vec<(String, i64)> {
    let mut delays = Vec::new();
    let mut last_run: Option<i64> = None;
    for record in records {
        match &record.entry {
            Entry::Decided {
                decision: Decision::Run { .. },
            } => last_run = Some(record.time_ns),
            Entry::ProgramStarted { state, pid, .. } => {
                let suffix = format!("-{pid}");
                let up = history
                    .first_seen
                    .iter()
                    .filter(|(client, _)| client.ends_with(&suffix))
                    .map(|(_, t)| *t)
                    .min();
                if let (Some(run), Some(up)) = (last_run.take(), up) {
                    delays.push((state.clone(), (up - run).max(0)));
                }
            }
            _ => {}
        }
    }
    delays
}

/// The recorded script: as the sequencer was given it (absolute, or relative to where it
/// ran, which is often here), else beside the recording.
fn find_script(script: &Path, recording: &Recording) -> PathBuf {
    if script.is_absolute() || script.is_file() {
        return script.to_path_buf();
    }
    recording
        .paths()
        .next()
        .and_then(Path::parent)
        .map(|dir| dir.join(script))
        .filter(|p| p.is_file())
        .unwrap_or_else(|| script.to_path_buf())
}

/// What the recorded broker decisions say of the live run.
#[derive(Debug, Default)]
struct BrokerHistory {
    /// Every death of a service's process: the service, when, and how it is lived again.
    deaths: Vec<(String, i64, FaultKind)>,
    /// When each client first appears in a decision (its first request answered).
    first_seen: BTreeMap<String, i64>,
}

impl BrokerHistory {
    /// Reads `/lewis/broker`. A service whose process died is one the broker scheduled a
    /// restart of, or gave up after such a restart (the demo kills the laser again after
    /// every restart). A service given up at its first death (no restart allowed) is not
    /// told apart from one that could not start, and is left out.
    ///
    /// A death the broker restarted after is lived again as a crash. One it gave up at is
    /// lived again as a stuck loop, which the broker fails at once whatever its count: live
    /// it may have given up for a stall (a killed process whose heartbeats stopped before
    /// its exit was seen), which a crash would turn into one more restart.
    fn read(recording: &Recording, robot: &Robot) -> Self {
        let mut history = Self::default();
        let Ok(messages) = recording.messages_on(&[names::BROKER_CHANNEL]) else {
            return history;
        };
        for message in messages.flatten() {
            let Ok(decision) = cdr::from_bytes::<BrokerMessage>(&message.data) else {
                continue;
            };
            if !decision.client.is_empty() {
                history
                    .first_seen
                    .entry(decision.client.clone())
                    .or_insert(decision.at_ns);
            }
            let died = match BrokerAction::parse(&decision.action) {
                Some(BrokerAction::RestartScheduled)
                    if robot.service(&decision.service).is_some() =>
                {
                    Some(FaultKind::Crash)
                }
                Some(BrokerAction::ServiceFailed)
                    if history.deaths.iter().any(|(s, ..)| *s == decision.service) =>
                {
                    Some(FaultKind::Stuck)
                }
                _ => None,
            };
            if let Some(kind) = died {
                history
                    .deaths
                    .push((decision.service.clone(), decision.at_ns, kind));
            }
        }
        history
    }

    /// Each death applied again at its time as a fault of an instant (a crash, or a stuck
    /// loop where the broker gave up): the process dies then, and a restart after it runs
    /// until the next death, as it did live.
    fn deaths(&self, start_ns: i64) -> Vec<Fault> {
        self.deaths
            .iter()
            .map(|(provider, at_ns, kind)| Fault {
                spec: format!("{provider}@{}:{kind}", format_seconds(at_ns - start_ns)),
                provider: provider.clone(),
                kind: *kind,
                at_ns: *at_ns,
                until_ns: Some(at_ns + 1),
            })
            .collect()
    }
}
