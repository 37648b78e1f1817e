//! How far re-simulated outputs are from the recorded ones, per output channel.
//!
//! Messages are paired in order of publication; when both sides name their inputs
//! (provenance) and they disagree, the pairing skips ahead on the side that has the other's
//! inputs later, so one lost or extra message does not shift every later pair. The headers
//! are not compared (publish times are the live clock on one side and the virtual clock on
//! the other); every other field is, numbers within a tolerance, anything else exactly.
//! A message without a partner counts as differing.

use std::collections::{BTreeMap, VecDeque};

use lewis_interfaces::dynamic::{Decoder, Value};
use lewis_interfaces::msg::InputRef;
use serde::Serialize;

/// Messages waiting for a partner, per side, before the oldest counts as unmatched.
const MAX_PENDING: usize = 4096;
/// How far ahead provenance is searched for.
const LOOKAHEAD: usize = 64;

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
}

struct Pending {
    time_ns: i64,
    inputs: Vec<InputRef>,
    value: Option<Value>,
}

struct Channel {
    decoder: Option<Decoder>,
    recorded: VecDeque<Pending>,
    resimulated: VecDeque<Pending>,
    divergence: ChannelDivergence,
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

    /// Declares an output channel and the schema its messages are decoded with.
    pub fn add_channel(&mut self, channel: &str, schema_name: &str, schema_text: &str) {
        self.channels
            .entry(channel.to_owned())
            .or_insert_with(|| Channel {
                decoder: Decoder::new(schema_name, schema_text).ok(),
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
                },
            });
    }

    /// Whether `channel` is compared.
    #[must_use]
    pub fn has_channel(&self, channel: &str) -> bool {
        self.channels.contains_key(channel)
    }

    /// A recorded message of an output channel.
    pub fn recorded(&mut self, channel: &str, time_ns: i64, bytes: &[u8]) {
        self.push(channel, time_ns, bytes, true);
    }

    /// A re-simulated message of an output channel (named as recorded).
    pub fn resimulated(&mut self, channel: &str, time_ns: i64, bytes: &[u8]) {
        self.push(channel, time_ns, bytes, false);
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
                c.divergence.clone()
            })
            .collect()
    }

    fn push(&mut self, channel: &str, time_ns: i64, bytes: &[u8], recorded: bool) {
        let (tolerance, start_ns) = (self.tolerance, self.start_ns);
        let Some(c) = self.channels.get_mut(channel) else {
            return;
        };
        let value = c.decoder.as_ref().and_then(|d| d.decode(bytes).ok());
        let inputs = lewis_runtime::service::Input {
            interface: "",
            provider: "",
            channel,
            bytes,
        }
        .header()
        .map(|h| h.inputs)
        .unwrap_or_default();
        let pending = Pending {
            time_ns,
            inputs,
            value,
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
    fn pair(&mut self, tolerance: f64, start_ns: i64) {
        while let (Some(r), Some(s)) = (self.recorded.front(), self.resimulated.front()) {
            if !r.inputs.is_empty() && !s.inputs.is_empty() && r.inputs != s.inputs {
                // Skip ahead on the side that has the other's inputs later.
                if let Some(skip) = position(&self.recorded, &s.inputs) {
                    for _ in 0..skip {
                        if let Some(p) = self.recorded.pop_front() {
                            unmatched(&mut self.divergence, p.time_ns - start_ns);
                        }
                    }
                    continue;
                }
                if let Some(skip) = position(&self.resimulated, &r.inputs) {
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
            let mut max = 0.0f64;
            let same = match (&r.value, &s.value) {
                (Some(a), Some(b)) => same_value(a, b, tolerance, &mut max, true),
                _ => false,
            };
            self.divergence.max_numeric_difference =
                self.divergence.max_numeric_difference.max(max);
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

fn position(queue: &VecDeque<Pending>, inputs: &[InputRef]) -> Option<usize> {
    queue
        .iter()
        .take(LOOKAHEAD)
        .position(|p| p.inputs == inputs)
}

fn unmatched(divergence: &mut ChannelDivergence, at_ns: i64) {
    divergence.differing += 1;
    if divergence.first_divergence_ns.is_none_or(|t| at_ns < t) {
        divergence.first_divergence_ns = Some(at_ns);
    }
}

/// Whether two values are the same within `tolerance`; `max` gets the largest numeric
/// difference seen. At the top level the `header` field is skipped.
fn same_value(a: &Value, b: &Value, tolerance: f64, max: &mut f64, top: bool) -> bool {
    if let (Some(x), Some(y)) = (number(a), number(b)) {
        if x.is_nan() && y.is_nan() {
            return true;
        }
        let difference = (x - y).abs();
        if difference.is_finite() {
            *max = max.max(difference);
        } else if x != y {
            *max = f64::INFINITY;
        }
        return x == y || difference <= tolerance;
    }
    match (a, b) {
        (Value::Array(x), Value::Array(y)) => {
            let mut same = x.len() == y.len();
            for (x, y) in x.iter().zip(y) {
                same &= same_value(x, y, tolerance, max, false);
            }
            same
        }
        (Value::Struct(x), Value::Struct(y)) => {
            let mut same = x.len() == y.len();
            for ((name_x, x), (name_y, y)) in x.iter().zip(y) {
                if top && &**name_x == "header" {
                    continue;
                }
                same &= name_x == name_y && same_value(x, y, tolerance, max, false);
            }
            same
        }
        _ => a == b,
    }
}

/// A value as a number, when it is one.
#[allow(clippy::cast_precision_loss)]
fn number(value: &Value) -> Option<f64> {
    match value {
        Value::Int(i) => Some(*i as f64),
        Value::UInt(u) => Some(*u as f64),
        Value::Float(f) => Some(*f),
        _ => None,
    }
}

#[cfg(test)]
mod tests {
    use lewis_interfaces::cdr;
    use lewis_interfaces::msg::{Distance, Header};
    use lewis_interfaces::{Interface, Struct};

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
    ) {
        let mut comparator = Comparator::new(1e-6, 0);
        comparator.add_channel("/d/Distance", Distance::SCHEMA_NAME, Distance::SCHEMA_TEXT);
        for (i, (input, m)) in recorded.iter().enumerate() {
            let t = i64::try_from(*input).unwrap() * 100;
            comparator.recorded("/d/Distance", t, &distance(i as u64 + 1, *input, *m));
        }
        for (i, (input, m)) in resimulated.iter().enumerate() {
            let t = i64::try_from(*input).unwrap() * 100;
            comparator.resimulated("/d/Distance", t, &distance(i as u64 + 1, *input, *m));
        }
        let d = &comparator.finish()[0];
        assert_eq!(
            (d.compared, d.differing, d.first_divergence_ns),
            (expected.0, expected.1, expected.2),
            "{d:?}"
        );
        assert!(
            (d.max_numeric_difference - expected.3).abs() < 1e-12,
            "{d:?}"
        );
        let _ = Distance::NAME;
    }

    #[test]
    fn identical_outputs_do_not_diverge_whatever_their_headers_say() {
        check(
            &[(1, 1.0), (2, 2.0)],
            &[(1, 1.0), (2, 2.0)],
            (2, 0, None, 0.0),
        );
    }

    #[test]
    fn a_difference_beyond_the_tolerance_is_counted_with_its_time_and_size() {
        check(
            &[(1, 1.0), (2, 2.0)],
            &[(1, 1.0), (2, 2.5)],
            (2, 1, Some(200), 0.5),
        );
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
}
