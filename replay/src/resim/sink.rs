//! Where a replay's results go as they happen: the output recording (the recorded messages
//! copied, what the harness produced beside them under [`REPLAY_PREFIX`]), the comparison
//! with the recording, and the watch on the broker's reactions to each fault. Nothing here
//! keeps more than a bounded amount of the run.

use std::collections::{BTreeMap, BTreeSet};

use lewis_interfaces::msg::{
    Broker as BrokerMessage, GroundTruth, Health as HealthMessage, LogLine, LogLineLevel,
    LogLineStream,
};
use lewis_interfaces::{Interface, cdr};
use lewis_recorder::{ChannelId, ChannelSpec, RecordError, Recorder, STATS_TOPIC, Sample};
use lewis_runtime::broker::live::decision_message;
use lewis_runtime::live::health_fields;
use lewis_runtime::names;

use super::{FAULTS_TOPIC, REPLAY_PREFIX, REPLAY_PROVIDER};
use crate::compare::Comparator;
use crate::lockstep::{Emitted, Sink};
use crate::report::{Failure, FaultWatch, MAX_FAILURES};
use lewis_recording::{RecordedMessage, Topic};

/// Writes everything into the output recording, feeds the comparator and the fault
/// watches.
/// The simulator's last GroundTruth, recorded and re-simulated: where the robot ended.
#[derive(Debug, Default)]
pub(super) struct Truth {
    recorded: Option<GroundTruth>,
    replayed: Option<GroundTruth>,
}

impl Truth {
    pub(super) fn recorded(&self) -> Option<&GroundTruth> {
        self.recorded.as_ref()
    }

    pub(super) fn replayed(&self) -> Option<&GroundTruth> {
        self.replayed.as_ref()
    }
}

pub(super) struct OutputSink {
    /// `None`: nothing is written (a sweep wants the report only).
    pub(super) recorder: Option<Recorder>,
    pub(super) truth: Truth,
    pub(super) comparator: Comparator,
    pub(super) watches: Vec<FaultWatch>,
    pub(super) decisions: u64,
    /// The failures decided, at most [`MAX_FAILURES`].
    pub(super) failures: Vec<Failure>,
    pub(super) written: u64,
    pub(super) error: Option<RecordError>,
    /// Recorded messages are not copied (`ReplayOptions::outputs_only`).
    pub(super) outputs_only: bool,
    /// Interfaces not written (`ReplayOptions::left_out`).
    pub(super) left_out: BTreeSet<String>,
    /// Each topic's channel in the output; `None`: not written (its interface left out).
    channels: BTreeMap<String, Option<ChannelId>>,
    seqs: BTreeMap<String, u64>,
}

impl OutputSink {
    pub(super) fn new(
        recorder: Option<Recorder>,
        comparator: Comparator,
        watches: Vec<FaultWatch>,
    ) -> Self {
        Self {
            recorder,
            comparator,
            watches,
            truth: Truth::default(),
            decisions: 0,
            failures: Vec::new(),
            written: 0,
            error: None,
            outputs_only: false,
            left_out: BTreeSet::new(),
            channels: BTreeMap::new(),
            seqs: BTreeMap::new(),
        }
    }

    fn channel(&mut self, spec: impl FnOnce() -> ChannelSpec, topic: &str) -> Option<ChannelId> {
        if let Some(id) = self.channels.get(topic) {
            return *id;
        }
        let recorder = self.recorder.as_mut()?;
        let spec = spec();
        if self.left_out.contains(&spec.interface) {
            self.channels.insert(topic.to_owned(), None);
            return None;
        }
        match recorder.add_channel(spec) {
            Ok(id) => {
                self.channels.insert(topic.to_owned(), Some(id));
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
        let Some(recorder) = self.recorder.as_mut() else {
            return;
        };
        match recorder.write(&sample) {
            Ok(()) => self.written += 1,
            Err(e) => self.error = Some(e),
        }
    }

    /// A recorded message, due now in replay order: copied (but the recorder's own stats,
    /// which the new file has afresh, an older replay's channels, and anything with
    /// `outputs_only`), and compared when it is an output of a re-simulated service.
    pub(super) fn recorded(
        &mut self,
        topic: Option<&Topic>,
        message: &RecordedMessage,
        at_ns: i64,
    ) {
        let name = &*message.topic;
        if name == STATS_TOPIC || name.starts_with(&format!("{REPLAY_PREFIX}/")) {
            return;
        }
        let copied = !self.outputs_only;
        // As it was, metadata and all: a channel numbered per publisher stays so.
        let spec = || {
            topic.map_or_else(
                || ChannelSpec {
                    topic: name.to_owned(),
                    schema_name: String::new(),
                    schema_text: String::new(),
                    provider: String::new(),
                    interface: String::new(),
                    interface_version: String::new(),
                    extra_metadata: BTreeMap::new(),
                },
                Topic::channel_spec,
            )
        };
        if copied && let Some(id) = self.channel(spec, name) {
            self.write(
                id,
                message.seq,
                message.publish_time_ns,
                message.log_time_ns,
                &message.data,
            );
        }
        if self.comparator.has_channel(name) {
            self.comparator.recorded(name, at_ns, &message.data);
        }
        if topic.and_then(|t| t.interface.as_deref()) == Some(GroundTruth::NAME)
            && let Ok(truth) = cdr::from_bytes(&message.data)
        {
            self.truth.recorded = Some(truth);
        }
    }

    fn next_seq(&mut self, topic: &str) -> u64 {
        let seq = self.seqs.entry(topic.to_owned()).or_insert(0);
        *seq += 1;
        *seq
    }

    /// Writes a message the replay made itself (header filled here, but for `keep_header`).
    fn own<T: Interface>(&mut self, topic: &str, provider: &str, time_ns: i64, mut message: T) {
        let seq = self.next_seq(topic);
        let header = message.header_mut();
        provider.clone_into(&mut header.provider);
        header.seq = seq;
        header.publish_time_ns = time_ns;
        self.write_own(topic, provider, time_ns, seq, &message);
    }

    fn write_own<T: Interface>(
        &mut self,
        topic: &str,
        provider: &str,
        time_ns: i64,
        seq: u64,
        message: &T,
    ) -> Vec<u8> {
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
        let bytes = cdr::to_vec(message);
        if let Some(id) = self.channel(spec, topic) {
            self.write(id, seq, time_ns, time_ns, &bytes);
        }
        bytes
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
                if interface == GroundTruth::NAME
                    && let Ok(truth) = cdr::from_bytes(bytes)
                {
                    self.truth.replayed = Some(truth);
                }
            }
            Emitted::Decision(decision) => {
                self.decisions += 1;
                for watch in &mut self.watches {
                    watch.decision(decision);
                }
                let topic = format!("{REPLAY_PREFIX}{}", names::BROKER_CHANNEL);
                let message: BrokerMessage = decision_message(decision);
                if self.failures.len() < MAX_FAILURES
                    && let Some(failure) = Failure::of(&message)
                {
                    self.failures.push(failure);
                }
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
                    state: state.into(),
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
                // The harness numbered and stamped it as the live harness does.
                let recorded_topic = names::command_log_channel(service);
                let topic = format!("{REPLAY_PREFIX}{recorded_topic}");
                let bytes = self.write_own(&topic, service, time_ns, log.header.seq, log);
                self.comparator
                    .resimulated(&recorded_topic, time_ns, &bytes);
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
                    stream: LogLineStream::Replay.into(),
                    level: LogLineLevel::from(level).into(),
                    text: text.to_owned(),
                    ..LogLine::default()
                };
                self.own(&topic, REPLAY_PROVIDER, time_ns, message);
            }
            Emitted::Mission(record) => {
                let topic = format!("{REPLAY_PREFIX}{}", names::SEQUENCER_CHANNEL);
                let message = lewis_sequencer::to_message(record);
                self.own(&topic, names::SEQUENCER_NODE, record.time_ns, message);
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
                    stream: LogLineStream::Fault.into(),
                    level: LogLineLevel::Warn.into(),
                    text,
                    ..LogLine::default()
                };
                self.own(FAULTS_TOPIC, REPLAY_PROVIDER, time_ns, message);
            }
        }
    }
}
