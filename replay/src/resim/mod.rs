//! `lewis replay`: re-simulates a recording in the [`Lockstep`] harness and writes a new
//! recording with the recorded inputs, the re-simulated outputs beside them, the broker's
//! decisions and the injected faults, plus a [`Report`].
//!
//! - **What is re-simulated** ([`ServiceSelection`]): by default every service of the stored
//!   robot but the sources, which are fed from the recording. A source is a service that
//!   requires nothing, or whose kind is one of [`ReplayOptions::source_kinds`] (the binary
//!   names the kinds that talk to a device or to the simulated world: `sim-laser` requires
//!   the simulator's GroundTruth, yet it is the laser); `--services A,B` names them; `--all` takes every service
//!   this binary can build. A service the recording has nothing of (it never ran live, like
//!   a sonar started on demand only after a fault) cannot be fed: it is re-simulated, when
//!   its kind is known, and its outputs are not compared.
//! - **Output channels**: everything recorded is copied unchanged (but the recorder's own
//!   stats, which the new file has afresh); what the replay produced goes under
//!   [`REPLAY_PREFIX`]: `/replay/<service>/<Interface>`, `/replay/lewis/broker`,
//!   `/replay/lewis/health/<service>`, `/replay/lewis/commands/<service>`,
//!   `/replay/lewis/log`, and the faults on `/replay/lewis/faults` (LogLine messages whose
//!   stream is `fault`).
//! - **Determinism**: the output is written by the recorder library with the virtual time
//!   as log time; nothing on the way reads a clock, iterates a hash map or uses a thread,
//!   so the same recording, code and options give the same bytes.

use std::collections::{BTreeMap, BTreeSet};
use std::path::{Path, PathBuf};

use lewis_interfaces::msg::{
    Broker as BrokerMessage, CommandLog, Health as HealthMessage, LogLine,
};
use lewis_interfaces::{Interface, cdr};
use lewis_recorder::{
    ChannelId, ChannelSpec, Compression, RecordError, Recorder, RecorderOptions, RobotDescription,
    STATS_TOPIC, Sample,
};
use lewis_runtime::broker::Decision;
use lewis_runtime::broker::live::decision_message;
use lewis_runtime::live::health_fields;
use lewis_runtime::names;
use lewis_runtime::robot::{Launch, Robot};
use lewis_runtime::service::{ServiceConfig, ServiceRegistry};

use crate::compare::Comparator;
use crate::fault::{Fault, FaultError, FaultSpec};
use crate::lockstep::{CommandBook, Emitted, Lockstep, LockstepError, Plan, Route, Sink, route};
use crate::recording::{Recording, RecordingError};
use crate::report::{CheckOutcome, Report, fault_report};

/// The prefix of every channel the replay writes.
pub const REPLAY_PREFIX: &str = "/replay";
/// The channel of injected faults.
pub const FAULTS_TOPIC: &str = "/replay/lewis/faults";
/// The default absolute tolerance of the comparison.
pub const DEFAULT_TOLERANCE: f64 = 1e-6;
/// The provider name of the messages the replay itself writes.
const REPLAY_PROVIDER: &str = "lewis-replay";

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
    /// The kinds of service that are sources even though they require something.
    pub source_kinds: BTreeSet<String>,
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
            source_kinds: BTreeSet::new(),
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
    /// The output cannot be written.
    #[error("writing the replay: {0}")]
    Record(#[from] RecordError),
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

/// Where the replay of `input` goes by default: `RUN.replay.mcap` beside `RUN.mcap`.
#[must_use]
pub fn default_output(input: &Path) -> PathBuf {
    let stem = input
        .file_stem()
        .map_or_else(|| "run".to_owned(), |s| s.to_string_lossy().into_owned());
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
    source_kinds: &BTreeSet<String>,
) -> Result<BTreeSet<String>, ReplayError> {
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
            Route::Broker | Route::Other => None,
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
                        known: robot
                            .services
                            .iter()
                            .map(|s| s.name.as_str())
                            .collect::<Vec<_>>()
                            .join(", "),
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

/// Replays a recording (see the module documentation) and returns the report.
///
/// # Errors
/// When the recording cannot be read, an option does not fit it, a service cannot be
/// built, or the output cannot be written.
pub fn replay(
    options: &ReplayOptions,
    registry: &ServiceRegistry,
    progress: &mut dyn FnMut(Progress),
) -> Result<Report, ReplayError> {
    let recording = Recording::open(&options.inputs)?;
    let robot = recording.robot().clone();
    let (start_ns, end_ns) = (recording.start_ns(), recording.end_ns());
    let faults = options
        .faults
        .iter()
        .map(|spec| spec.resolve(&robot, start_ns, end_ns))
        .collect::<Result<Vec<Fault>, _>>()?;
    let resimulated = select_services(
        &robot,
        &recording,
        registry,
        &options.services,
        &options.source_kinds,
    )?;
    let ran: BTreeSet<String> = recording
        .topics()
        .values()
        .filter(|t| t.message_count > 0)
        .filter_map(|t| match route(&t.name, &robot) {
            Route::Data { service, .. } | Route::Health { service } => Some(service),
            _ => None,
        })
        .collect();
    let book = command_book(&recording, &robot, &resimulated)?;
    let output = options
        .output
        .clone()
        .unwrap_or_else(|| default_output(&options.inputs[0]));
    prepare_output(&output, &options.inputs)?;

    let (file_name, toml) = recording.robot_toml();
    let mut recorder_options = RecorderOptions::new(&output);
    recorder_options.compression = options.compression;
    recorder_options.robot_description = Some(RobotDescription {
        file_name: file_name.to_owned(),
        toml: toml.to_owned(),
    });
    recorder_options.sync_on_flush = false;
    recorder_options.disk_reserve_bytes = 0;
    REPLAY_PROVIDER.clone_into(&mut recorder_options.recorder_name);
    let recorder = Recorder::create(recorder_options)?;

    let mut comparator = Comparator::new(options.tolerance, start_ns);
    for name in resimulated.iter().filter(|n| ran.contains(*n)) {
        let Some(spec) = robot.service(name) else {
            continue;
        };
        for provision in &spec.provides {
            let topic = names::data_channel(name, &provision.interface);
            if let Some(info) = lewis_interfaces::interface_info(&provision.interface) {
                comparator.add_channel(&topic, info.publication.name, info.publication.text);
            }
        }
    }
    let mut sink = OutputSink {
        recorder,
        channels: BTreeMap::new(),
        comparator,
        decisions: Vec::new(),
        seqs: BTreeMap::new(),
        written: 0,
        error: None,
    };
    let plan = Plan {
        resimulated: resimulated.clone(),
        faults: faults.clone(),
        book,
    };
    let mut harness = Lockstep::new(&robot, registry, plan)?;
    harness.start(start_ns, &mut sink);
    let mut read = 0u64;
    for message in recording.messages()? {
        let message = message?;
        read += 1;
        harness.advance_to(message.log_time_ns, &mut sink);
        sink.recorded(&recording, &message.topic, &message);
        harness.feed(&message, &mut sink);
        if let Some(e) = sink.error.take() {
            return Err(e.into());
        }
        if read.is_multiple_of(512) {
            progress(Progress {
                done_ns: message.log_time_ns - start_ns,
                total_ns: end_ns - start_ns,
                messages: read,
            });
        }
    }
    harness.finish(end_ns, &mut sink);
    if let Some(e) = sink.error.take() {
        return Err(e.into());
    }
    progress(Progress {
        done_ns: end_ns - start_ns,
        total_ns: end_ns - start_ns,
        messages: read,
    });
    let stats = harness.stats().clone();
    let longest_gap = harness.longest_gap().cloned().map(|mut g| {
        g.from_ns -= start_ns;
        g.to_ns -= start_ns;
        g
    });
    drop(harness);
    let OutputSink {
        recorder,
        comparator,
        decisions,
        written,
        ..
    } = sink;
    recorder.close()?;
    let divergence = comparator.finish();
    let check = CheckOutcome::of(options.tolerance, &divergence);
    Ok(Report {
        inputs: options
            .inputs
            .iter()
            .map(|p| p.display().to_string())
            .collect(),
        output: output.display().to_string(),
        robot: robot.name.clone(),
        start_ns,
        duration_ns: end_ns - start_ns,
        resimulated: resimulated.iter().cloned().collect(),
        fed: robot
            .services
            .iter()
            .filter(|s| !resimulated.contains(&s.name))
            .map(|s| s.name.clone())
            .collect(),
        messages_read: read,
        messages_written: written,
        decisions: u64::try_from(decisions.len()).unwrap_or(u64::MAX),
        faults: faults
            .iter()
            .map(|f| fault_report(f, &decisions, start_ns))
            .collect(),
        longest_gap,
        divergence,
        harness: stats,
        check,
    })
}

/// The recorded answers of the services that are fed from the log.
fn command_book(
    recording: &Recording,
    robot: &Robot,
    resimulated: &BTreeSet<String>,
) -> Result<CommandBook, ReplayError> {
    let topics: Vec<String> = robot
        .services
        .iter()
        .filter(|s| !resimulated.contains(&s.name))
        .map(|s| names::command_log_channel(&s.name))
        .filter(|t| recording.topics().contains_key(t.as_str()))
        .collect();
    let mut book = CommandBook::new();
    if topics.is_empty() {
        return Ok(book);
    }
    let topic_refs: Vec<&str> = topics.iter().map(String::as_str).collect();
    for message in recording.messages_on(&topic_refs)? {
        let message = message?;
        let Route::Commands { service } = route(&message.topic, robot) else {
            continue;
        };
        if let Ok(log) = cdr::from_bytes::<CommandLog>(&message.data) {
            book.add(&service, message.log_time_ns, &log);
        }
    }
    Ok(book)
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

/// Writes everything into the output recording and feeds the comparator.
struct OutputSink {
    recorder: Recorder,
    channels: BTreeMap<String, ChannelId>,
    comparator: Comparator,
    decisions: Vec<Decision>,
    seqs: BTreeMap<String, u64>,
    written: u64,
    error: Option<RecordError>,
}

impl OutputSink {
    fn channel(&mut self, spec: impl FnOnce() -> ChannelSpec, topic: &str) -> Option<ChannelId> {
        if let Some(id) = self.channels.get(topic) {
            return Some(*id);
        }
        match self.recorder.add_channel(spec()) {
            Ok(id) => {
                self.channels.insert(topic.to_owned(), id);
                Some(id)
            }
            Err(e) => {
                self.error.get_or_insert(e);
                None
            }
        }
    }

    fn write(&mut self, channel: ChannelId, seq: u64, publish_ns: i64, log_ns: i64, data: &[u8]) {
        if self.error.is_some() {
            return;
        }
        let sample = Sample {
            channel,
            seq,
            publish_time_ns: publish_ns,
            log_time_ns: log_ns,
            data,
        };
        match self.recorder.write(&sample) {
            Ok(()) => self.written += 1,
            Err(e) => self.error = Some(e),
        }
    }

    fn recorded(
        &mut self,
        recording: &Recording,
        topic: &str,
        message: &crate::recording::RecordedMessage,
    ) {
        if topic == STATS_TOPIC || topic.starts_with(&format!("{REPLAY_PREFIX}/")) {
            return;
        }
        let spec = || {
            let t = recording.topics().get(topic);
            ChannelSpec {
                topic: topic.to_owned(),
                schema_name: t.map(|t| t.schema_name.clone()).unwrap_or_default(),
                schema_text: t.map(|t| t.schema_text.clone()).unwrap_or_default(),
                provider: t.and_then(|t| t.provider.clone()).unwrap_or_default(),
                interface: t.and_then(|t| t.interface.clone()).unwrap_or_default(),
                interface_version: t
                    .and_then(|t| t.interface_version.clone())
                    .unwrap_or_default(),
                extra_metadata: BTreeMap::new(),
            }
        };
        if let Some(id) = self.channel(spec, topic) {
            self.write(
                id,
                message.seq,
                message.publish_time_ns,
                message.log_time_ns,
                &message.data,
            );
        }
        if self.comparator.has_channel(topic) {
            self.comparator
                .recorded(topic, message.log_time_ns, &message.data);
        }
    }

    fn next_seq(&mut self, topic: &str) -> u64 {
        let seq = self.seqs.entry(topic.to_owned()).or_insert(0);
        *seq += 1;
        *seq
    }

    /// Writes a message the replay made itself (header filled here).
    fn own<T: Interface>(&mut self, topic: &str, provider: &str, time_ns: i64, mut message: T) {
        let seq = self.next_seq(topic);
        let header = message.header_mut();
        provider.clone_into(&mut header.provider);
        header.seq = seq;
        header.publish_time_ns = time_ns;
        let spec = || {
            let mut spec = ChannelSpec {
                topic: topic.to_owned(),
                schema_name: T::SCHEMA_NAME.to_owned(),
                schema_text: T::SCHEMA_TEXT.to_owned(),
                provider: provider.to_owned(),
                interface: T::NAME.to_owned(),
                interface_version: T::VERSION.to_owned(),
                extra_metadata: BTreeMap::new(),
            };
            spec.extra_metadata
                .insert("replay".to_owned(), "true".to_owned());
            spec
        };
        if let Some(id) = self.channel(spec, topic) {
            let bytes = cdr::to_vec(&message);
            self.write(id, seq, time_ns, time_ns, &bytes);
        }
    }
}

impl Sink for OutputSink {
    fn emit(&mut self, event: Emitted<'_>) {
        match event {
            Emitted::Publication {
                service,
                interface,
                time_ns,
                seq,
                bytes,
            } => {
                let recorded_topic = names::data_channel(service, interface);
                let topic = format!("{REPLAY_PREFIX}{recorded_topic}");
                let Some(info) = lewis_interfaces::interface_info(interface) else {
                    return;
                };
                let spec = || {
                    let mut spec = ChannelSpec::publication(info, service, &topic);
                    spec.extra_metadata
                        .insert("replay".to_owned(), "true".to_owned());
                    spec
                };
                if let Some(id) = self.channel(spec, &topic) {
                    self.write(id, seq, time_ns, time_ns, bytes);
                }
                self.comparator.resimulated(&recorded_topic, time_ns, bytes);
            }
            Emitted::Decision(decision) => {
                self.decisions.push(decision.clone());
                let topic = format!("{REPLAY_PREFIX}{}", names::BROKER_CHANNEL);
                let message: BrokerMessage = decision_message(decision);
                self.own(&topic, names::BROKER_NODE, decision.at_ns, message);
            }
            Emitted::Health {
                service,
                time_ns,
                health,
            } => {
                let (state, reason) = health_fields(health);
                let topic = format!("{REPLAY_PREFIX}{}", names::health_channel(service));
                let message = HealthMessage {
                    state: state.to_owned(),
                    reason: reason.to_owned(),
                    ..HealthMessage::default()
                };
                self.own(&topic, service, time_ns, message);
            }
            Emitted::Command {
                service,
                time_ns,
                log,
            } => {
                let topic = format!("{REPLAY_PREFIX}{}", names::command_log_channel(service));
                self.own(&topic, service, time_ns, log.clone());
            }
            Emitted::Log {
                service,
                time_ns,
                level,
                text,
            } => {
                let topic = format!("{REPLAY_PREFIX}{}", names::LOG_CHANNEL);
                let message = LogLine {
                    service: service.to_owned(),
                    stream: "replay".to_owned(),
                    level: level.to_string(),
                    text: text.to_owned(),
                    ..LogLine::default()
                };
                self.own(&topic, REPLAY_PROVIDER, time_ns, message);
            }
            Emitted::Fault {
                fault,
                time_ns,
                starts,
            } => {
                let text = if starts {
                    format!(
                        "fault injected: {} {} ({})",
                        fault.provider, fault.kind, fault.spec
                    )
                } else {
                    format!("fault ends: {} recovers ({})", fault.provider, fault.spec)
                };
                let message = LogLine {
                    service: fault.provider.clone(),
                    stream: "fault".to_owned(),
                    level: "warn".to_owned(),
                    text,
                    ..LogLine::default()
                };
                self.own(FAULTS_TOPIC, REPLAY_PROVIDER, time_ns, message);
            }
        }
    }
}
