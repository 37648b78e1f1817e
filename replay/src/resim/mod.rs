//! `lewis replay`: re-simulates a recording in the [`Lockstep`] harness and writes a new
//! recording with the recorded inputs, the re-simulated outputs beside them, the broker's
//! decisions and the injected faults, plus a [`Report`].
//!
//! - **What is re-simulated** ([`ServiceSelection`]): by default every service of the stored
//!   robot but the sources, which are fed from the recording. A source is a service that
//!   requires nothing, or whose kind the registry calls a device
//!   ([`lewis_service::Role`]: the kinds that talk to a device or to the simulated world;
//!   `sim-laser` requires the simulator's GroundTruth, yet it is the laser); `--services A,B` names them; `--all`
//!   takes every service this binary can build. A service the recording has nothing of (it
//!   never ran live, like a sonar started on demand only after a fault) cannot be fed: it is
//!   re-simulated, when its kind is known, and its outputs are not compared.
//! - **Following the recording**: a re-simulated service whose outputs are in the recording
//!   and whose tick rate is unchanged follows it (see [`crate::lockstep`]): an unchanged
//!   service reproduces its recorded outputs exactly, so `--check` is a regression test.
//! - **Another robot** ([`edit`]): `--robot FILE` replays with another robot description,
//!   `--set SERVICE.PARAMETER=VALUE` changes one parameter; the report lists what differs.
//! - **Reading**: several files, or a rotated recording's parts index (`STEM.parts.json`),
//!   are one run ([`Recording`]); it is streamed chunk by chunk through a bounded window
//!   ([`lookahead`]) that hands messages over in replay order; the comparison, the command
//!   book and the fault reports are bounded too, so memory does not grow with the
//!   recording's length.
//! - **Output channels**: everything recorded is copied unchanged (but the recorder's own
//!   stats, which the new file has afresh; nothing with [`ReplayOptions::outputs_only`], and
//!   no channel of an interface in [`ReplayOptions::left_out`]); what the replay produced goes under
//!   [`REPLAY_PREFIX`]: `/replay/<service>/<Interface>`, `/replay/lewis/broker`,
//!   `/replay/lewis/health/<service>`, `/replay/lewis/commands/<service>`,
//!   `/replay/lewis/log`, and the faults on `/replay/lewis/faults` (LogLine messages whose
//!   stream is `fault`).
//! - **Determinism**: the output is written by the recorder library with the virtual time
//!   as log time; nothing on the way reads a clock, iterates a hash map or uses a thread,
//!   so the same recording, code and options give the same bytes.

pub mod closure;
pub mod edit;
pub mod lookahead;
mod sink;

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use lewis_recorder::{Compression, RecordError, Recorder, RecorderOptions, RobotDescription};
use lewis_robot::{Launch, Robot};
use lewis_runtime::names;
use lewis_service::{ServiceConfig, ServiceRegistry};

use crate::compare::Comparator;
use crate::fault::{Fault, FaultError, FaultSpec};
use crate::lockstep::{Feed, Lockstep, LockstepError, Plan, Programs, Route, route};
use crate::outcome::{LoopKind, MissionOutcome, MissionReport};
use crate::report::{CheckOutcome, Failure, FaultWatch, Report};
use edit::{EditError, ParamEdit, ReplayedRobot, replayed_robot};
use lewis_recording::{ReadAhead, Recording, RecordingError};
use lookahead::Lookahead;
use sink::OutputSink;

/// The prefix of every channel the replay writes.
pub const REPLAY_PREFIX: &str = "/replay";
/// The channel of injected faults.
pub const FAULTS_TOPIC: &str = "/replay/lewis/faults";
/// The default absolute tolerance of the comparison.
pub const DEFAULT_TOLERANCE: f64 = 1e-6;
/// The provider name of the messages the replay itself writes.
pub(crate) const REPLAY_PROVIDER: &str = "lewis-replay";

/// Which services to re-simulate.
#[derive(Debug, Clone, PartialEq, Eq, Default)]
pub enum ServiceSelection {
    /// Every service but the sources (see the module documentation).
    #[default]
    NonSources,
    /// These services.
    Only(Vec<String>),
    /// Every service whose kind this binary can build.
    All,
}

/// How to replay.
#[derive(Debug, Clone)]
pub struct ReplayOptions {
    /// The recording's files.
    pub inputs: Vec<PathBuf>,
    /// The output file (`None`: [`default_output`] of the first input).
    pub output: Option<PathBuf>,
    /// What to re-simulate.
    pub services: ServiceSelection,
    /// The faults to inject.
    pub faults: Vec<FaultSpec>,
    /// The absolute tolerance on numbers when comparing outputs.
    pub tolerance: f64,
    /// The output's chunk compression.
    pub compression: Compression,
    /// Another robot description to replay with (`--robot`).
    pub robot: Option<PathBuf>,
    /// Parameter changes (`--set`).
    pub set: Vec<ParamEdit>,
    /// Whether the output recording is written (a fault sweep needs only the reports).
    pub write_output: bool,
    /// Write only what the replay produced (the [`REPLAY_PREFIX`] channels), not a copy of
    /// the recorded channels, which the recording holds already (`--outputs-only`). The
    /// comparison and the report are unchanged.
    pub outputs_only: bool,
    /// Interfaces whose channels, recorded or re-simulated, are not written to the output
    /// (`--leave-out ImageSource`: camera frames are most of a recording's bytes). They are
    /// still compared.
    pub left_out: BTreeSet<String>,
    /// With a mission lived again, the check compares the re-simulated outputs with the
    /// recorded ones too, not only the mission's states and outcome (`--check-outputs`).
    pub check_outputs: bool,
}

impl ReplayOptions {
    /// Replays `inputs` with the defaults: non-sources re-simulated, no fault, output
    /// next to the first input.
    #[must_use]
    pub fn new(inputs: Vec<PathBuf>) -> Self {
        Self {
            inputs,
            output: None,
            services: ServiceSelection::NonSources,
            faults: Vec::new(),
            tolerance: DEFAULT_TOLERANCE,
            compression: Compression::Zstd,
            robot: None,
            set: Vec::new(),
            write_output: true,
            outputs_only: false,
            left_out: BTreeSet::new(),
            check_outputs: false,
        }
    }
}

/// How far the replay is, for a progress bar.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Progress {
    /// Virtual time replayed, from the start.
    pub done_ns: i64,
    /// The recording's length.
    pub total_ns: i64,
    /// Recorded messages read.
    pub messages: u64,
}

/// Why a replay failed.
#[derive(Debug, thiserror::Error)]
pub enum ReplayError {
    /// The recording cannot be read.
    #[error(transparent)]
    Recording(#[from] RecordingError),
    /// A fault SPEC is not valid for this recording.
    #[error(transparent)]
    Fault(#[from] FaultError),
    /// The harness cannot be set up.
    #[error(transparent)]
    Lockstep(#[from] LockstepError),
    /// `--robot` or `--set` cannot be applied.
    #[error(transparent)]
    Edit(#[from] EditError),
    /// The output cannot be written.
    #[error("writing the replay: {0}")]
    Record(#[from] RecordError),
    /// The thread that reads the recording ahead could not be started.
    #[error("starting the thread that reads the recording: {0}")]
    ReadThread(std::io::Error),
    /// `--services` names a service the robot does not have.
    #[error(
        "--services names `{service}`, which the recorded robot does not have; it has: {known}"
    )]
    UnknownService {
        /// The name.
        service: String,
        /// The services it has.
        known: String,
    },
    /// `--services` names a service that cannot run in the harness.
    #[error("--services names `{service}`, which cannot be re-simulated: {reason}")]
    NotRunnable {
        /// The name.
        service: String,
        /// Why.
        reason: String,
    },
    /// The output would overwrite an input.
    #[error("the output {path} is one of the recordings replayed: choose another with -o")]
    OutputIsInput {
        /// The path.
        path: PathBuf,
    },
    /// An old output file cannot be replaced.
    #[error("cannot replace {path}: {source}")]
    Replace {
        /// The path.
        path: PathBuf,
        /// What the system said.
        source: std::io::Error,
    },
}

/// Where the replay of `input` goes by default: `RUN.replay.mcap` beside `RUN.mcap` (and
/// beside `RUN.parts.json`, the parts index of a rotated `RUN.mcap`).
#[must_use]
pub fn default_output(input: &Path) -> PathBuf {
    let stem = input
        .file_stem()
        .map_or_else(|| "run".to_owned(), |s| s.to_string_lossy().into_owned());
    let stem = stem.strip_suffix(".parts").unwrap_or(&stem);
    input.with_file_name(format!("{stem}.replay.mcap"))
}

/// Which services of `robot` to re-simulate for `selection`, given the topics of the
/// recording, the kinds `registry` knows and the kinds that are sources.
///
/// # Errors
/// When `--services` names an unknown service or one that cannot run in the harness.
pub fn select_services(
    robot: &Robot,
    recording: &Recording,
    registry: &ServiceRegistry,
    selection: &ServiceSelection,
) -> Result<BTreeSet<String>, ReplayError> {
    let source_kinds = registry.source_kinds();
    let kinds: BTreeSet<&str> = registry.kinds().into_iter().collect();
    let buildable = |name: &str| -> Result<(), String> {
        match robot.service(name).map(|s| &s.launch) {
            Some(Launch::Kind(kind)) if kinds.contains(kind.as_str()) => Ok(()),
            Some(Launch::Kind(kind)) => Err(format!(
                "its kind `{kind}` is not one this lewis knows ({})",
                registry.kinds().join(", ")
            )),
            Some(Launch::Command(_)) => {
                Err("it is started from its own command line, not a kind".to_owned())
            }
            None => Err("no such service".to_owned()),
        }
    };
    let ran: BTreeSet<String> = recording
        .topics()
        .values()
        .filter(|t| t.message_count > 0)
        .filter_map(|t| match route(&t.name, robot) {
            Route::Data { service, .. }
            | Route::Health { service }
            | Route::Commands { service } => Some(service),
            Route::Broker | Route::Cpu | Route::Hosts | Route::Other => None,
        })
        .collect();
    let mut chosen = BTreeSet::new();
    match selection {
        ServiceSelection::NonSources => {
            for spec in &robot.services {
                let source = spec.requires.is_empty()
                    || matches!(&spec.launch, Launch::Kind(kind) if source_kinds.contains(kind));
                if !source && buildable(&spec.name).is_ok() {
                    chosen.insert(spec.name.clone());
                }
            }
        }
        ServiceSelection::All => {
            for spec in &robot.services {
                if buildable(&spec.name).is_ok() {
                    chosen.insert(spec.name.clone());
                }
            }
        }
        ServiceSelection::Only(names) => {
            for name in names {
                if robot.service(name).is_none() {
                    return Err(ReplayError::UnknownService {
                        service: name.clone(),
                        known: robot.service_names(),
                    });
                }
                buildable(name).map_err(|reason| ReplayError::NotRunnable {
                    service: name.clone(),
                    reason,
                })?;
                chosen.insert(name.clone());
            }
        }
    }
    // What never ran live cannot be fed: run it if it can be built here.
    for spec in &robot.services {
        let config = ServiceConfig {
            spec,
            heartbeat_period_ms: robot.broker.heartbeat_period_ms,
        };
        if !ran.contains(&spec.name)
            && buildable(&spec.name).is_ok()
            && registry.build(&config).is_ok()
        {
            chosen.insert(spec.name.clone());
        }
    }
    Ok(chosen)
}

/// What a replay runs, worked out from the recording and the options.
#[derive(Debug)]
pub struct Prepared {
    /// The robot replayed, and what differs from the recorded one.
    pub replayed: ReplayedRobot,
    /// The faults placed on the recording's clock.
    pub faults: Vec<Fault>,
    /// The services re-simulated.
    pub resimulated: BTreeSet<String>,
    /// The services whose publications the recording holds.
    pub published: BTreeSet<String>,
    /// The harness's plan.
    pub plan: Plan,
    /// With `--all`: whether the loop closes, and the mission to live again; without it,
    /// the recorded mission only (for its verdict).
    pub closure: closure::Closure,
}

/// Works out what a replay of `recording` with `options` runs; `programs` builds the
/// programs of a recorded mission, to live it again with `--all`.
///
/// # Errors
/// When an option does not fit the recording, or the recording cannot be read.
pub fn prepare(
    recording: &Recording,
    options: &ReplayOptions,
    registry: &ServiceRegistry,
    programs: Option<&dyn Programs>,
) -> Result<Prepared, ReplayError> {
    let (file_name, toml) = recording.robot_toml();
    let replayed = replayed_robot(
        recording.robot(),
        file_name,
        toml,
        options.robot.as_deref(),
        &options.set,
    )?;
    let robot = &replayed.robot;
    let mut selection = options.services.clone();
    let closure = if selection == ServiceSelection::All {
        let closure = closure::close(
            recording,
            robot,
            &registry.source_kinds(),
            &registry.simulated_kinds(),
            programs,
        );
        if closure.open_because.is_some() {
            // Open loop: the recorded sources are fed as they were.
            selection = ServiceSelection::NonSources;
        }
        closure
    } else {
        closure::Closure {
            recorded: closure::recorded_mission(recording),
            ..closure::Closure::default()
        }
    };
    let (start_ns, end_ns) = (recording.start_ns(), recording.end_ns());
    let overtime_ns = if closure.mission.is_some() && closure.loop_kind() == LoopKind::Closed {
        overtime(start_ns, end_ns)
    } else {
        0
    };
    let faults = options
        .faults
        .iter()
        .map(|spec| spec.resolve(robot, start_ns, end_ns, overtime_ns))
        .collect::<Result<Vec<Fault>, _>>()?;
    let resimulated = select_services(robot, recording, registry, &selection)?;
    edit::check_edits_resimulated(&options.set, &resimulated)?;
    let published = services_with_outputs(recording, robot);
    let followed = followed_services(recording, robot, registry, &resimulated, &published);
    // The live run's own faults act in the harness; the report watches the injected ones.
    let mut acting = faults.clone();
    acting.extend(closure.recorded_faults.iter().cloned());
    let plan = Plan {
        resimulated: resimulated.clone(),
        ready_at: first_heartbeats(recording, robot, &followed)?,
        followed,
        faults: acting,
    };
    Ok(Prepared {
        replayed,
        faults,
        resimulated,
        published,
        plan,
        closure,
    })
}

/// Replays a recording (see the module documentation) and returns the report; a recorded
/// mission is not lived again (see [`replay_with`]).
///
/// # Errors
/// When the recording cannot be read, an option does not fit it, a service cannot be
/// built, or the output cannot be written.
pub fn replay(
    options: &ReplayOptions,
    registry: &ServiceRegistry,
    progress: &mut dyn FnMut(Progress),
) -> Result<Report, ReplayError> {
    replay_with(options, registry, None, progress)
}

/// How long a replay goes on after the mission lived again is over (its last outputs).
const AFTER_MISSION_NS: i64 = 2_000_000_000;

/// How long a mission lived again may go on past the end of the recording, as a multiple
/// of the recording's length: a fault may make it slower, not endless.
const OVERTIME: i64 = 1;

/// How long past the end of a recording spanning `start_ns..=end_ns` a mission lived again
/// may run (and a fault be placed).
fn overtime(start_ns: i64, end_ns: i64) -> i64 {
    (end_ns - start_ns).saturating_mul(OVERTIME)
}

/// Replays a recording as [`replay`] does; with `--all` and `programs`, a recorded
/// mission is lived again in the closed loop ([`closure`]).
///
/// # Errors
/// As [`replay`].
pub fn replay_with(
    options: &ReplayOptions,
    registry: &ServiceRegistry,
    programs: Option<&dyn Programs>,
    progress: &mut dyn FnMut(Progress),
) -> Result<Report, ReplayError> {
    let recording = Recording::open(&options.inputs)?;
    let Prepared {
        replayed,
        faults,
        resimulated,
        published,
        plan,
        closure,
    } = prepare(&recording, options, registry, programs)?;
    let robot = &replayed.robot;
    let (start_ns, end_ns) = (recording.start_ns(), recording.end_ns());
    let followed = plan.followed.clone();
    let output = options
        .output
        .clone()
        .unwrap_or_else(|| default_output(&options.inputs[0]));
    // The files read, parts indexes expanded: none of them may be replaced.
    let read: Vec<PathBuf> = recording.paths().map(Path::to_path_buf).collect();
    if options.write_output {
        prepare_output(&output, &read)?;
    }

    let mut recorder_options = RecorderOptions::new(&output);
    recorder_options.compression = options.compression;
    recorder_options.robot_description = Some(RobotDescription {
        file_name: replayed.file_name.clone(),
        toml: replayed.toml.clone(),
    });
    recorder_options.sync_on_flush = false;
    recorder_options.disk_reserve_bytes = 0;
    REPLAY_PROVIDER.clone_into(&mut recorder_options.recorder_name);
    // The output's name stays out of its bytes: two replays to different names are one file.
    recorder_options.file_label = Some("replay".to_owned());
    let recorder = if options.write_output {
        Some(Recorder::create(recorder_options)?)
    } else {
        None
    };
    let comparator = comparator(
        &recording,
        robot,
        &resimulated,
        &published,
        options,
        start_ns,
    );
    let watches = faults
        .iter()
        .map(|f| FaultWatch::new(f.clone(), robot))
        .collect();
    let mut sink = OutputSink::new(recorder, comparator, watches);
    sink.outputs_only = options.outputs_only;
    sink.left_out.clone_from(&options.left_out);

    let mut harness = Lockstep::new(robot, registry, plan)?;
    if let (Some(mission), Some(programs)) = (closure.mission.clone(), programs) {
        harness.with_mission(mission, programs);
    }
    let messages = ReadAhead::new(recording.messages()?).map_err(ReplayError::ReadThread)?;
    let mut window = Lookahead::new(messages);
    // The broker comes up with the first message, once the window shows what lies ahead.
    let first = window
        .peek_time(&mut |m, t| harness.preview(m, t))?
        .unwrap_or(start_ns);
    harness.start(first.min(start_ns), &mut sink);
    let mut read = 0u64;
    let mut last_ns = start_ns;
    while let Some((at_ns, message)) = window.next(&mut |m, t| harness.preview(m, t))? {
        if window.read_whole() {
            harness.read_whole();
        }
        read += 1;
        last_ns = last_ns.max(at_ns);
        // A mission lived again is over: live, `lewis up --script` would stop the robot. The
        // rest of the recording is only copied.
        let lived_on = harness
            .mission_over_at()
            .is_none_or(|over| at_ns <= over.saturating_add(AFTER_MISSION_NS));
        if lived_on {
            harness.advance_to(at_ns, &mut sink);
        }
        sink.recorded(recording.topics().get(&message.topic), &message, at_ns);
        if lived_on {
            harness.feed(&message, at_ns, &mut sink);
        }
        if let Some(e) = sink.error.take() {
            return Err(e.into());
        }
        if read.is_multiple_of(512) {
            progress(Progress {
                done_ns: (at_ns - start_ns).clamp(0, end_ns - start_ns),
                total_ns: end_ns - start_ns,
                messages: read,
            });
        }
    }
    let limit_ns = end_ns.saturating_add(overtime(start_ns, end_ns));
    harness.finish_mission(limit_ns, &mut sink);
    let end_of_run = harness
        .mission_over_at()
        .map_or(end_ns.max(last_ns), |over| {
            over.saturating_add(AFTER_MISSION_NS)
        })
        .max(harness.now_ns());
    harness.finish(end_of_run, &mut sink);
    if let Some(e) = sink.error.take() {
        return Err(e.into());
    }
    progress(Progress {
        done_ns: end_ns - start_ns,
        total_ns: end_ns - start_ns,
        messages: read,
    });
    let stats = harness.stats().clone();
    let feeds = harness
        .feeds()
        .map(|feed| Feed {
            first_ns: feed.first_ns - start_ns,
            last_ns: feed.last_ns - start_ns,
            ..feed.clone()
        })
        .collect();
    let longest_gap = harness.longest_gap().cloned().map(|mut g| {
        g.from_ns -= start_ns;
        g.to_ns -= start_ns;
        g
    });
    let replayed_records = harness.mission_records().to_vec();
    let answers = harness
        .mission_answers()
        .iter()
        .map(|a| crate::lockstep::Answer {
            time_ns: a.time_ns - start_ns,
            ..a.clone()
        })
        .collect();
    drop(harness);
    let OutputSink {
        recorder,
        comparator,
        watches,
        decisions,
        failures,
        written,
        truth,
        ..
    } = sink;
    if let Some(recorder) = recorder {
        recorder.close()?;
    }
    let divergence = comparator.finish();
    let mission = mission_report(
        &closure,
        &replayed_records,
        answers,
        &truth,
        longest_gap.clone(),
        start_ns,
    );
    let mut check = CheckOutcome::of(options.tolerance, &divergence);
    // Lived again, the outputs differ from the live ones by the noise of live timing (live
    // ticks land a little late, replayed ones on time), and the closed loop amplifies it:
    // the check of a mission is its course and outcome, and its outputs only when asked.
    // Only a mission lived again has a replayed course to compare.
    if let Some(course) = mission.as_ref().and_then(MissionReport::same_course) {
        check = check.of_mission(course, options.check_outputs);
    }
    Ok(Report {
        inputs: options
            .inputs
            .iter()
            .map(|p| p.display().to_string())
            .collect(),
        output: output.display().to_string(),
        robot: robot.name.clone(),
        robot_description: replayed.source.clone(),
        parameter_changes: replayed
            .changes
            .iter()
            .filter(|(service, _)| resimulated.contains(service))
            .map(|(_, change)| change.clone())
            .collect(),
        start_ns,
        duration_ns: end_ns - start_ns,
        resimulated: resimulated.iter().cloned().collect(),
        followed: followed.iter().cloned().collect(),
        fed: robot
            .services
            .iter()
            .filter(|s| !resimulated.contains(&s.name))
            .map(|s| s.name.clone())
            .collect(),
        messages_read: read,
        messages_written: written,
        decisions,
        faults: watches.into_iter().map(|w| w.report(start_ns)).collect(),
        failures: failures
            .into_iter()
            .map(|f| Failure {
                at_ns: f.at_ns - start_ns,
                ..f
            })
            .collect(),
        longest_gap,
        feeds,
        divergence,
        harness: stats,
        check,
        mission,
    })
}

/// The mission part of the report: the recorded verdict, and the replayed one when the
/// loop was closed.
fn mission_report(
    closure: &closure::Closure,
    replayed_records: &[lewis_sequencer::Record],
    answers: Vec<crate::lockstep::Answer>,
    truth: &sink::Truth,
    longest_blind: Option<crate::lockstep::Gap>,
    start_ns: i64,
) -> Option<MissionReport> {
    let loop_kind = closure.loop_kind();
    let closed = loop_kind == LoopKind::Closed;
    // Without `--all` and without a recorded mission there is nothing to say.
    if closure.recorded.is_empty() && !closure.asked {
        return None;
    }
    let recorded = (!closure.recorded.is_empty())
        .then(|| MissionOutcome::of(&closure.recorded, start_ns, truth.recorded(), None));
    let replayed = (closed && !replayed_records.is_empty())
        .then(|| MissionOutcome::of(replayed_records, start_ns, truth.replayed(), longest_blind));
    let final_pose_distance_m = recorded
        .as_ref()
        .and_then(|r| r.final_pose)
        .zip(replayed.as_ref().and_then(|r| r.final_pose))
        .map(|(a, b)| (a[0] - b[0]).hypot(a[1] - b[1]));
    Some(MissionReport {
        loop_kind,
        recorded,
        replayed,
        answers,
        recorded_faults: closure
            .recorded_faults
            .iter()
            .map(|f| f.spec.clone())
            .collect(),
        final_pose_distance_m,
    })
}

/// The services whose publications the recording holds.
fn services_with_outputs(recording: &Recording, robot: &Robot) -> BTreeSet<String> {
    recording
        .topics()
        .values()
        .filter(|t| t.message_count > 0)
        .filter_map(|t| match route(&t.name, robot) {
            Route::Data { service, .. } => Some(service),
            _ => None,
        })
        .collect()
}

/// The re-simulated services that follow the recording: those with recorded outputs whose
/// tick period is the same in the robot replayed as in the robot recorded (with another
/// rate, the recorded tick times mean nothing: the service ticks at its own).
fn followed_services(
    recording: &Recording,
    robot: &Robot,
    registry: &ServiceRegistry,
    resimulated: &BTreeSet<String>,
    published: &BTreeSet<String>,
) -> BTreeSet<String> {
    let tick = |robot: &Robot, name: &str| {
        let spec = robot.service(name)?;
        let config = ServiceConfig {
            spec,
            heartbeat_period_ms: robot.broker.heartbeat_period_ms,
        };
        registry.build(&config).ok().map(|s| s.tick_period_ns())
    };
    resimulated
        .iter()
        .filter(|name| published.contains(*name))
        .filter(|name| tick(recording.robot(), name) == tick(robot, name))
        .cloned()
        .collect()
}

/// The replay time of the first recorded heartbeat of each of `services`: when its process
/// came up live. Read from the start of the recording, only as far as needed.
fn first_heartbeats(
    recording: &Recording,
    robot: &Robot,
    services: &BTreeSet<String>,
) -> Result<BTreeMap<String, i64>, ReplayError> {
    let topics: Vec<String> = services
        .iter()
        .map(|s| names::health_channel(s))
        .filter(|t| recording.topics().contains_key(t.as_str()))
        .collect();
    let mut found = BTreeMap::new();
    if topics.is_empty() {
        return Ok(found);
    }
    let topic_refs: Vec<&str> = topics.iter().map(String::as_str).collect();
    for message in recording.messages_on(&topic_refs)? {
        let message = message?;
        if let Route::Health { service } = route(&message.topic, robot) {
            found
                .entry(service)
                .or_insert_with(|| lookahead::replay_time(&message));
        }
        if found.len() == topics.len() {
            break;
        }
    }
    Ok(found)
}

/// The comparator of the outputs of the re-simulated services that ran live: their data
/// channels and their command logs.
fn comparator(
    recording: &Recording,
    robot: &Robot,
    resimulated: &BTreeSet<String>,
    published: &BTreeSet<String>,
    options: &ReplayOptions,
    start_ns: i64,
) -> Comparator {
    let mut comparator = Comparator::new(options.tolerance, start_ns);
    for name in resimulated {
        let Some(spec) = robot.service(name) else {
            continue;
        };
        if published.contains(name) {
            for provision in &spec.provides {
                let topic = names::data_channel(name, &provision.interface);
                if let Some(info) = lewis_interfaces::interface_info(&provision.interface) {
                    comparator.add_channel(&topic, info.publication.name, info.publication.text);
                }
            }
        }
        let commands = names::command_log_channel(name);
        if recording
            .topics()
            .get(commands.as_str())
            .is_some_and(|t| t.message_count > 0)
        {
            comparator.add_command_channel(&commands);
        }
    }
    comparator
}

fn prepare_output(output: &Path, inputs: &[PathBuf]) -> Result<(), ReplayError> {
    let same = |a: &Path, b: &Path| match (a.canonicalize(), b.canonicalize()) {
        (Ok(a), Ok(b)) => a == b,
        _ => a == b,
    };
    if inputs.iter().any(|i| same(i, output)) {
        return Err(ReplayError::OutputIsInput {
            path: output.to_path_buf(),
        });
    }
    if output.is_file() {
        std::fs::remove_file(output).map_err(|source| ReplayError::Replace {
            path: output.to_path_buf(),
            source,
        })?;
    }
    Ok(())
}
