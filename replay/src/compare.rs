//! How far re-simulated outputs are from the recorded ones, per output channel: the data a
//! re-simulated service published, and the commands it answered (its command log).
//!
//! Messages are paired in order of publication; when both sides say what they answer (the
//! inputs named in a publication's provenance, the caller and number of a command) and they
//! disagree, the pairing skips ahead on the side that has the other's later, so one lost or
//! extra message does not shift every later pair. Headers are not compared (a replay
//! re-numbers and re-stamps what it re-simulates); every other field is, numbers within a
//! tolerance, anything else exactly; a command is compared by its name, status, error and
//! the fields of its request and reply. A message without a partner counts as differing.
//!
//! Messages waiting for a partner are kept as bytes and decoded only when paired, at most
//! [`MAX_PENDING`] per side and channel, so the comparison takes bounded memory whatever
//! the recording's length.

use std::collections::{BTreeMap, VecDeque};
use std::sync::Arc;

use lewis_interfaces::cdr;
use lewis_interfaces::dynamic::{CompareOptions, Decoder, LargestDifference};
use lewis_interfaces::msg::{CommandLog, InputRef};
use lewis_service::Input;
use serde::Serialize;

use crate::lockstep::header_provider;

/// Messages waiting for a partner, per side, before the oldest counts as unmatched.
pub const MAX_PENDING: usize = 256;
/// How far ahead a partner is searched for.
const LOOKAHEAD: usize = 64;
/// Input channels listed per output channel, at most.
const MAX_INPUT_CHANNELS: usize = 16;

/// The divergence of one output channel.
#[derive(Debug, Clone, PartialEq, Serialize)]
pub struct ChannelDivergence {
    /// The recorded channel (the re-simulated one is the same under `/replay`).
    pub channel: String,
    /// Recorded messages.
    pub recorded: u64,
    /// Re-simulated messages.
    pub resimulated: u64,
    /// Pairs compared.
    pub compared: u64,
    /// Pairs that differ beyond the tolerance, plus messages without a partner.
    pub differing: u64,
    /// The virtual time of the first difference, from the start of the recording.
    pub first_divergence_ns: Option<i64>,
    /// The largest difference between two numbers of a compared pair.
    pub max_numeric_difference: f64,
    /// The field where that largest difference was (`target.x`, `request.y`).
    pub max_difference_field: Option<String>,
    /// The input channels the re-simulated messages name in their provenance: what they
    /// were computed from.
    pub resimulated_inputs: Vec<InputUse>,
}

/// How the re-simulated messages of a channel used one input channel.
#[derive(Debug, Clone, PartialEq, Eq, Serialize)]
pub struct InputUse {
    /// The input channel.
    pub channel: String,
    /// Re-simulated messages that name it.
    pub messages: u64,
    /// The time of the first of them, from the start of the recording.
    pub first_ns: i64,
    /// The time of the last of them, from the start of the recording.
    pub last_ns: i64,
}

/// What the messages of a channel are.
enum Kind {
    /// Publications, decoded with their schema (`None`: the schema does not parse, every
    /// pair differs).
    Data(Option<Decoder>),
    /// Command logs; requests and replies decoded with their interface's schemas.
    Commands(BTreeMap<(String, String), Option<(Decoder, Decoder)>>),
}

struct Pending {
    time_ns: i64,
    /// What the message answers, to pair it.
    key: Vec<InputRef>,
    bytes: Arc<[u8]>,
}

struct Channel {
    kind: Kind,
    recorded: VecDeque<Pending>,
    resimulated: VecDeque<Pending>,
    divergence: ChannelDivergence,
    inputs: BTreeMap<String, InputUse>,
}

/// Pairs and compares recorded and re-simulated outputs.
pub struct Comparator {
    tolerance: f64,
    start_ns: i64,
    channels: BTreeMap<String, Channel>,
}

impl std::fmt::Debug for Comparator {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("Comparator")
            .field("tolerance", &self.tolerance)
            .field("channels", &self.channels.keys().collect::<Vec<_>>())
            .finish()
    }
}

impl Comparator {
    /// A comparator with an absolute tolerance on numbers; times are reported from
    /// `start_ns`.
    #[must_use]
    pub fn new(tolerance: f64, start_ns: i64) -> Self {
        Self {
            tolerance,
            start_ns,
            channels: BTreeMap::new(),
        }
    }

    /// Declares an output channel of publications and the schema they are decoded with.
    pub fn add_channel(&mut self, channel: &str, schema_name: &str, schema_text: &str) {
        self.add(
            channel,
            Kind::Data(Decoder::new(schema_name, schema_text).ok()),
        );
    }

    /// Declares a command-log channel (`/lewis/commands/<service>`).
    pub fn add_command_channel(&mut self, channel: &str) {
        self.add(channel, Kind::Commands(BTreeMap::new()));
    }

    fn add(&mut self, channel: &str, kind: Kind) {
        self.channels
            .entry(channel.to_owned())
            .or_insert_with(|| Channel {
                kind,
                recorded: VecDeque::new(),
                resimulated: VecDeque::new(),
                divergence: ChannelDivergence {
                    channel: channel.to_owned(),
                    recorded: 0,
                    resimulated: 0,
                    compared: 0,
                    differing: 0,
                    first_divergence_ns: None,
                    max_numeric_difference: 0.0,
                    max_difference_field: None,
                    resimulated_inputs: Vec::new(),
                },
                inputs: BTreeMap::new(),
            });
    }

    /// Whether `channel` is compared.
    #[must_use]
    pub fn has_channel(&self, channel: &str) -> bool {
        self.channels.contains_key(channel)
    }

    /// A recorded message of an output channel (shared, not copied: camera frames are
    /// large).
    pub fn recorded(&mut self, channel: &str, time_ns: i64, bytes: &Arc<[u8]>) {
        self.push(channel, time_ns, bytes, true);
    }

    /// A re-simulated message of an output channel (named as recorded).
    pub fn resimulated(&mut self, channel: &str, time_ns: i64, bytes: &[u8]) {
        if self.channels.contains_key(channel) {
            self.push(channel, time_ns, &Arc::from(bytes), false);
        }
    }

    /// Counts what is left unpaired and returns the divergence of every channel.
    #[must_use]
    pub fn finish(mut self) -> Vec<ChannelDivergence> {
        let start_ns = self.start_ns;
        self.channels
            .values_mut()
            .map(|c| {
                while let Some(p) = c.recorded.pop_front() {
                    unmatched(&mut c.divergence, p.time_ns - start_ns);
                }
                while let Some(p) = c.resimulated.pop_front() {
                    unmatched(&mut c.divergence, p.time_ns - start_ns);
                }
                c.divergence.resimulated_inputs = c.inputs.values().cloned().collect();
                c.divergence.clone()
            })
            .collect()
    }

    fn push(&mut self, channel: &str, time_ns: i64, bytes: &Arc<[u8]>, recorded: bool) {
        let (tolerance, start_ns) = (self.tolerance, self.start_ns);
        let Some(c) = self.channels.get_mut(channel) else {
            return;
        };
        let key = match c.kind {
            Kind::Data(_) => header_inputs(channel, bytes),
            Kind::Commands(_) => command_key(bytes),
        };
        if !recorded && matches!(c.kind, Kind::Data(_)) {
            c.note_inputs(&key, time_ns - start_ns);
        }
        let pending = Pending {
            time_ns,
            key,
            bytes: bytes.clone(),
        };
        if recorded {
            c.divergence.recorded += 1;
            c.recorded.push_back(pending);
        } else {
            c.divergence.resimulated += 1;
            c.resimulated.push_back(pending);
        }
        c.pair(tolerance, start_ns);
    }
}

impl Channel {
    fn note_inputs(&mut self, inputs: &[InputRef], at_ns: i64) {
        for input in inputs {
            if !self.inputs.contains_key(&input.channel) && self.inputs.len() >= MAX_INPUT_CHANNELS
            {
                continue;
            }
            let used = self
                .inputs
                .entry(input.channel.clone())
                .or_insert_with(|| InputUse {
                    channel: input.channel.clone(),
                    messages: 0,
                    first_ns: at_ns,
                    last_ns: at_ns,
                });
            used.messages += 1;
            used.last_ns = at_ns;
        }
    }

    fn pair(&mut self, tolerance: f64, start_ns: i64) {
        while let (Some(r), Some(s)) = (self.recorded.front(), self.resimulated.front()) {
            if !r.key.is_empty() && !s.key.is_empty() && r.key != s.key {
                // Skip ahead on the side that has the other's key later.
                if let Some(skip) = position(&self.recorded, &s.key) {
                    for _ in 0..skip {
                        if let Some(p) = self.recorded.pop_front() {
                            unmatched(&mut self.divergence, p.time_ns - start_ns);
                        }
                    }
                    continue;
                }
                if let Some(skip) = position(&self.resimulated, &r.key) {
                    for _ in 0..skip {
                        if let Some(p) = self.resimulated.pop_front() {
                            unmatched(&mut self.divergence, p.time_ns - start_ns);
                        }
                    }
                    continue;
                }
            }
            let (Some(r), Some(s)) = (self.recorded.pop_front(), self.resimulated.pop_front())
            else {
                break;
            };
            self.divergence.compared += 1;
            let mut max = LargestDifference::default();
            let same =
                r.bytes == s.bytes || self.kind.same(&r.bytes, &s.bytes, tolerance, &mut max);
            if max.difference > self.divergence.max_numeric_difference {
                self.divergence.max_numeric_difference = max.difference;
                self.divergence.max_difference_field = max.field;
            }
            if !same {
                self.divergence.differing += 1;
                let at = s.time_ns.min(r.time_ns) - start_ns;
                if self.divergence.first_divergence_ns.is_none_or(|t| at < t) {
                    self.divergence.first_divergence_ns = Some(at);
                }
            }
        }
        for queue in [&mut self.recorded, &mut self.resimulated] {
            while queue.len() > MAX_PENDING {
                if let Some(p) = queue.pop_front() {
                    unmatched(&mut self.divergence, p.time_ns - start_ns);
                }
            }
        }
    }
}

impl Kind {
    /// Whether two messages of the channel are the same within `tolerance`, headers left
    /// out (a replay re-numbers and re-stamps what it re-simulates); a command log by its
    /// command, status, error, request and reply. `max` gets the largest numeric
    /// difference. Messages that do not decode are the same only when equal.
    fn same(&mut self, a: &[u8], b: &[u8], tolerance: f64, max: &mut LargestDifference) -> bool {
        let options = |path_prefix| CompareOptions {
            tolerance,
            skip_field: Some("header"),
            path_prefix,
        };
        match self {
            Self::Data(decoder) => decoder
                .as_ref()
                .and_then(|d| d.compare(a, b, &options(""), max).ok())
                .unwrap_or(false),
            Self::Commands(decoders) => {
                let (Ok(a), Ok(b)) = (
                    cdr::from_bytes::<CommandLog>(a),
                    cdr::from_bytes::<CommandLog>(b),
                ) else {
                    return false;
                };
                if (&a.interface, &a.command) != (&b.interface, &b.command) {
                    return false;
                }
                let Some((request, reply)) = decoders
                    .entry((a.interface.clone(), a.command.clone()))
                    .or_insert_with(|| command_decoders(&a.interface, &a.command))
                    .as_ref()
                else {
                    return false;
                };
                // A part that does not decode (an empty reply: the call failed) is the
                // same only when its bytes are.
                let mut part = |decoder: &Decoder, x: &[u8], y: &[u8], name| {
                    decoder
                        .compare(x, y, &options(name), max)
                        .unwrap_or_else(|_| x == y)
                };
                let same_request = part(request, &a.request, &b.request, "request");
                let same_reply = part(reply, &a.reply, &b.reply, "reply");
                a.status == b.status && a.error == b.error && same_request && same_reply
            }
        }
    }
}

fn command_decoders(interface: &str, command: &str) -> Option<(Decoder, Decoder)> {
    let info = lewis_interfaces::interface_info(interface)?;
    let command = info.commands.iter().find(|c| c.name == command)?;
    Some((
        Decoder::new(command.request.name, command.request.text).ok()?,
        Decoder::new(command.reply.name, command.reply.text).ok()?,
    ))
}

/// The inputs a publication names in its provenance.
fn header_inputs(channel: &str, bytes: &[u8]) -> Vec<InputRef> {
    Input {
        interface: "",
        provider: "",
        channel,
        bytes,
    }
    .header()
    .map(|h| h.inputs)
    .unwrap_or_default()
}

/// What a command log answers: the caller and the number of its call.
fn command_key(bytes: &[u8]) -> Vec<InputRef> {
    let Ok(log) = cdr::from_bytes::<CommandLog>(bytes) else {
        return Vec::new();
    };
    let seq = lewis_service::decode_header_seq(&log.request);
    vec![InputRef {
        channel: header_provider(&log.request),
        seq,
    }]
}

fn position(queue: &VecDeque<Pending>, key: &[InputRef]) -> Option<usize> {
    queue.iter().take(LOOKAHEAD).position(|p| p.key == key)
}

fn unmatched(divergence: &mut ChannelDivergence, at_ns: i64) {
    divergence.differing += 1;
    if divergence.first_divergence_ns.is_none_or(|t| at_ns < t) {
        divergence.first_divergence_ns = Some(at_ns);
    }
}

#[cfg(test)]
mod tests {
    use lewis_interfaces::msg::{Distance, Header, MoverGoto, MoverGotoReply};
    use lewis_interfaces::{Command, Struct};

    use super::*;

    fn distance(seq: u64, input_seq: u64, min_m: f64) -> Vec<u8> {
        cdr::to_vec(&Distance {
            header: Header {
                provider: "d".into(),
                seq,
                publish_time_ns: i64::try_from(seq).unwrap() * 7,
                inputs: vec![InputRef {
                    channel: "/laser/RangeFinder".into(),
                    seq: input_seq,
                }],
            },
            min_distance: min_m,
            ..Distance::default()
        })
    }

    fn check(
        recorded: &[(u64, f64)],
        resimulated: &[(u64, f64)],
        expected: (u64, u64, Option<i64>, f64),
    ) -> ChannelDivergence {
        let mut comparator = Comparator::new(1e-6, 0);
        comparator.add_channel("/d/Distance", Distance::SCHEMA_NAME, Distance::SCHEMA_TEXT);
        for (i, (input, m)) in recorded.iter().enumerate() {
            let t = i64::try_from(*input).unwrap() * 100;
            comparator.recorded(
                "/d/Distance",
                t,
                &Arc::from(distance(i as u64 + 1, *input, *m)),
            );
        }
        for (i, (input, m)) in resimulated.iter().enumerate() {
            let t = i64::try_from(*input).unwrap() * 100;
            comparator.resimulated("/d/Distance", t, &distance(i as u64 + 1, *input, *m));
        }
        let d = comparator.finish().remove(0);
        assert_eq!(
            (d.compared, d.differing, d.first_divergence_ns),
            (expected.0, expected.1, expected.2),
            "{d:?}"
        );
        assert!(
            (d.max_numeric_difference - expected.3).abs() < 1e-12,
            "{d:?}"
        );
        d
    }

    #[test]
    fn identical_outputs_do_not_diverge_whatever_their_headers_say() {
        let d = check(
            &[(1, 1.0), (2, 2.0)],
            &[(1, 1.0), (2, 2.0)],
            (2, 0, None, 0.0),
        );
        assert_eq!(
            d.resimulated_inputs,
            [InputUse {
                channel: "/laser/RangeFinder".into(),
                messages: 2,
                first_ns: 100,
                last_ns: 200,
            }]
        );
    }

    #[test]
    fn a_difference_beyond_the_tolerance_is_counted_with_its_time_size_and_field() {
        let d = check(
            &[(1, 1.0), (2, 2.0)],
            &[(1, 1.0), (2, 2.5)],
            (2, 1, Some(200), 0.5),
        );
        assert_eq!(d.max_difference_field.as_deref(), Some("min_distance"));
        check(&[(1, 1.0)], &[(1, 1.0 + 1e-9)], (1, 0, None, 1e-9));
    }

    #[test]
    fn a_lost_message_does_not_shift_the_later_pairs() {
        check(
            &[(1, 1.0), (2, 2.0), (3, 3.0)],
            &[(1, 1.0), (3, 3.0)],
            (2, 1, Some(200), 0.0),
        );
    }

    #[test]
    fn unpaired_messages_are_counted_and_not_kept() {
        let recorded: Vec<(u64, f64)> = (1..=2000).map(|i| (i, 1.0)).collect();
        let d = check(&recorded, &[], (0, 2000, Some(100), 0.0));
        assert_eq!(d.recorded, 2000);
    }

    #[test]
    fn commands_are_compared_by_their_arguments_and_answers() {
        let log = |seq: u64, x: f64, goal_id: i32| {
            let request = MoverGoto {
                header: Header {
                    provider: "avoider".into(),
                    seq,
                    ..Header::default()
                },
                x,
                y: 2.0,
            };
            cdr::to_vec(&CommandLog {
                interface: "Mover".into(),
                command: MoverGoto::NAME.into(),
                request: cdr::to_vec(&request),
                status: "ok".into(),
                reply: cdr::to_vec(&MoverGotoReply {
                    goal_id,
                    ..MoverGotoReply::default()
                }),
                ..CommandLog::default()
            })
        };
        let mut comparator = Comparator::new(1e-6, 0);
        comparator.add_command_channel("/lewis/commands/mover");
        comparator.recorded("/lewis/commands/mover", 10, &Arc::from(log(1, 1.0, 1)));
        comparator.recorded("/lewis/commands/mover", 20, &Arc::from(log(2, 3.0, 2)));
        comparator.resimulated("/lewis/commands/mover", 10, &log(1, 1.0, 1));
        comparator.resimulated("/lewis/commands/mover", 20, &log(2, 3.25, 2));
        let d = comparator.finish().remove(0);
        assert_eq!((d.compared, d.differing), (2, 1), "{d:?}");
        assert_eq!(d.first_divergence_ns, Some(20));
        assert!((d.max_numeric_difference - 0.25).abs() < 1e-12, "{d:?}");
        assert_eq!(d.max_difference_field.as_deref(), Some("request.x"));
    }
}
