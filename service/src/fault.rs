//! The one fault vocabulary of Lewis: the words users type for faults, what they mean, and
//! their parsing, in two families.
//!
//! - **Faults of a service** ([`ServiceFault`]): how a provider fails (`stall`, `crash`,
//!   `garbage`, `frozen`, ...). Each place that takes them takes its own part of the
//!   vocabulary ([`ServiceFaultWords`]): live faults (`lewis fault`, [`LIVE_FAULTS`]),
//!   replay's `--inject-fault PROVIDER@START:KIND` ([`REPLAY_FAULTS`]) and the fault file of
//!   the `test-range` emulator ([`FAULT_FILE_FAULTS`]); a word means the same everywhere.
//! - **Faults of a serial line** ([`LineFault`]): what the device emulators do to the bytes
//!   between a device and its driver (`noise=N` garbage bytes before every frame,
//!   `bad-crc-every=N` corrupted checksums, `silent`, `unplug@T1-T2`), read from a
//!   comma-separated list by [`parse_line_faults`] into a [`LineFaultPlan`]; the drivers'
//!   fault injector applies the bytes' part of it ([`LineFaults`]).
//!
//! Unknown words are refused naming the word and every word the place takes, with a did you
//! mean ([`lewis_stdx::closest`]) when one is near.

use std::fmt;
use std::time::Duration;

use lewis_interfaces::cdr;
use serde::Serialize;

/// How a service fails: the faults of a service.
///
/// The order is that of replay's reports and tables (it was replay's kind first).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash, Serialize)]
#[serde(rename_all = "kebab-case")]
pub enum ServiceFault {
    /// No data and no heartbeat, as a hung process: the broker sees the deadline pass.
    Stall,
    /// The process exits (SIGABRT, or SIGKILL from `lewis fault --kill`), and again at
    /// every restart while the fault lasts.
    Crash,
    /// Data that does not decode or is junk, heartbeats as usual.
    Garbage,
    /// The last good payload again and again (new headers), heartbeats as usual.
    Frozen,
    /// Two samples of three dropped, heartbeats as usual.
    Slow,
    /// No data; the heartbeats declare the provider out of service.
    OutOfService,
    /// The event loop sticks in one step: no data, and the heartbeat thread says so once
    /// before going silent; the broker fails it at once and stops its process.
    Stuck,
    /// A whole host cut off (its name given as the provider): nothing of its services is
    /// heard, and it joins again at the fault's end.
    HostLost,
    /// Readings that are NaN, heartbeats as usual.
    Nan,
    /// Works, but declares itself degraded.
    Degraded,
}

impl ServiceFault {
    /// Every fault of a service.
    pub const ALL: [Self; 10] = [
        Self::Stall,
        Self::Crash,
        Self::Garbage,
        Self::Frozen,
        Self::Slow,
        Self::OutOfService,
        Self::Stuck,
        Self::HostLost,
        Self::Nan,
        Self::Degraded,
    ];

    /// The word users type for it, the same wherever it is taken.
    #[must_use]
    pub const fn word(self) -> &'static str {
        match self {
            Self::Stall => "stall",
            Self::Crash => "crash",
            Self::Garbage => "garbage",
            Self::Frozen => "frozen",
            Self::Slow => "slow",
            Self::OutOfService => "out-of-service",
            Self::Stuck => "stuck",
            Self::HostLost => "host-lost",
            Self::Nan => "nan",
            Self::Degraded => "degraded",
        }
    }
}

impl fmt::Display for ServiceFault {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.word())
    }
}

/// The part of the vocabulary one place takes: some faults of a service, and perhaps a
/// word for "no fault" (written as `None` among them, where it is listed).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct ServiceFaultWords {
    /// The word for "no fault", when the place has one (`clear`, `ok`).
    pub none: Option<&'static str>,
    /// What the place takes, in the order its messages list them.
    pub faults: &'static [Option<ServiceFault>],
}

/// What a running service's harness can be put in (`lewis fault`, the fault channel):
/// `stall`, `out-of-service`, `frozen`, `garbage`, or `clear` for no fault. A crash needs
/// no harness: the process is killed (`lewis fault --kill`).
pub const LIVE_FAULTS: ServiceFaultWords = ServiceFaultWords {
    none: Some("clear"),
    faults: &[
        Some(ServiceFault::Stall),
        Some(ServiceFault::OutOfService),
        Some(ServiceFault::Frozen),
        Some(ServiceFault::Garbage),
        None,
    ],
};

/// The faults replay injects into a recording (`--inject-fault PROVIDER@START:KIND`).
pub const REPLAY_FAULTS: ServiceFaultWords = ServiceFaultWords {
    none: None,
    faults: &[
        Some(ServiceFault::Crash),
        Some(ServiceFault::Stall),
        Some(ServiceFault::Garbage),
        Some(ServiceFault::Frozen),
        Some(ServiceFault::Slow),
        Some(ServiceFault::OutOfService),
        Some(ServiceFault::Stuck),
        Some(ServiceFault::HostLost),
    ],
};

/// The words of the `test-range` emulator's fault file (`ok`, or an empty file, for none).
pub const FAULT_FILE_FAULTS: ServiceFaultWords = ServiceFaultWords {
    none: Some("ok"),
    faults: &[
        None,
        Some(ServiceFault::Degraded),
        Some(ServiceFault::OutOfService),
        Some(ServiceFault::Stall),
        Some(ServiceFault::Crash),
        Some(ServiceFault::Garbage),
        Some(ServiceFault::Nan),
        Some(ServiceFault::Frozen),
        Some(ServiceFault::Slow),
    ],
};

impl ServiceFaultWords {
    /// The word for `fault` (`None`: the word for no fault, or `""` when there is none).
    #[must_use]
    pub fn word(&self, fault: Option<ServiceFault>) -> &'static str {
        fault.map_or(self.none.unwrap_or(""), ServiceFault::word)
    }

    /// Every word taken, in order.
    pub fn words(&self) -> impl Iterator<Item = &'static str> + '_ {
        self.faults.iter().map(|&fault| self.word(fault))
    }

    /// Every word, comma-separated: `crash, stall, garbage`.
    #[must_use]
    pub fn names(&self) -> String {
        self.words().collect::<Vec<_>>().join(", ")
    }

    /// Every word as a sentence lists them: `stall, out-of-service or clear`.
    #[must_use]
    pub fn listed(&self) -> String {
        list_words(&self.words().collect::<Vec<_>>())
    }

    /// Whether the place takes `fault`.
    #[must_use]
    pub fn takes(&self, fault: Option<ServiceFault>) -> bool {
        self.faults.contains(&fault)
    }

    /// The fault `word` names here (`None`: the word for no fault).
    ///
    /// # Errors
    /// When the place takes no such word, with a did you mean when one is near.
    pub fn parse(&self, word: &str) -> Result<Option<ServiceFault>, UnknownFaultWord> {
        self.faults
            .iter()
            .copied()
            .find(|&fault| self.word(fault) == word)
            .ok_or_else(|| UnknownFaultWord::new(word, self.words(), self.listed()))
    }
}

/// A word that names no fault where it was written.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown fault `{word}`: expected {expected}{}", did_you_mean(*suggestion))]
pub struct UnknownFaultWord {
    /// The word as written.
    pub word: String,
    /// The words taken there, as a sentence lists them.
    pub expected: String,
    /// The word taken there that is nearest, when one is near.
    pub suggestion: Option<&'static str>,
}

impl UnknownFaultWord {
    fn new(
        word: &str,
        candidates: impl IntoIterator<Item = &'static str>,
        expected: String,
    ) -> Self {
        Self {
            word: word.to_owned(),
            expected,
            suggestion: lewis_stdx::closest(word, candidates),
        }
    }

    /// `; did you mean `stall`?` when a word is near, else nothing: for messages that name
    /// the word their own way.
    #[must_use]
    pub fn did_you_mean(&self) -> String {
        did_you_mean(self.suggestion)
    }
}

fn did_you_mean(suggestion: Option<&str>) -> String {
    suggestion.map_or_else(String::new, |word| format!("; did you mean `{word}`?"))
}

/// `a, b or c`.
fn list_words(words: &[&str]) -> String {
    match words {
        [] => String::new(),
        [one] => (*one).to_owned(),
        [rest @ .., last] => format!("{} or {last}", rest.join(", ")),
    }
}

/// What a serial line does to the bytes between a device and its driver, as the emulators
/// take it (`lewis fake-device --fault`): one item of a comma-separated list.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum LineFault {
    /// `noise=N`: N garbage bytes before every frame.
    Noise(u32),
    /// `bad-crc-every=N`: every N-th frame with a corrupted checksum (1: all, 0: none).
    BadCrcEvery(u32),
    /// `silent`: no answers, no streaming, as if the cable were cut.
    Silent,
    /// `unplug@T1-T2`: the cable pulled T1 after the start and put back at T2 (`unplug@T1`:
    /// for good).
    Unplug(Unplug),
    /// `none`: no fault (clears what came before it).
    None,
}

impl LineFault {
    /// The words of line faults (each item starts with one).
    pub const WORDS: [&'static str; 5] = ["noise", "bad-crc-every", "silent", "unplug", "none"];
}

/// The syntax of a line fault list, for error messages and `--help`.
pub const LINE_FAULT_SYNTAX: &str = "noise=N, bad-crc-every=N, silent, unplug@T1-T2 (or unplug@T1: for good; T as 5s, 1.5s or 500ms) or none, comma-separated";

/// A time the cable is pulled, and when it is put back (`None`: never).
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Unplug {
    /// After the start.
    pub at: Duration,
    /// When it is plugged back in, after the start.
    pub until: Option<Duration>,
}

/// The faults of a line's bytes that the drivers' fault injector applies; the default
/// injects none.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub struct LineFaults {
    /// Garbage bytes sent before every outgoing frame.
    pub noise_bytes: usize,
    /// Every n-th outgoing frame gets a corrupted checksum (0: never, 1: all of them).
    pub corrupt_checksum_every: u32,
    /// The device neither answers nor streams, as if its cable were cut.
    pub silent: bool,
}

/// A line fault list read: the faults of the bytes and the times the cable is pulled.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct LineFaultPlan {
    /// Faults of the device's bytes, from the start.
    pub faults: LineFaults,
    /// Unplugging windows, in time order, not overlapping.
    pub unplugs: Vec<Unplug>,
}

/// A line fault list that cannot be read.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum LineFaultError {
    /// An item that is none of the known faults.
    #[error("unknown fault `{item}`: use {LINE_FAULT_SYNTAX}{}", did_you_mean(*suggestion))]
    Unknown {
        /// The item.
        item: String,
        /// The fault word nearest the item's, when one is near.
        suggestion: Option<&'static str>,
    },
    /// A count that is not a non-negative integer.
    #[error("fault `{item}` needs a non-negative integer after `=`")]
    BadCount {
        /// The item.
        item: String,
    },
    /// A time that cannot be read.
    #[error("fault `{item}`: `{time}` is not a time: write it as 5s, 1.5s or 500ms")]
    BadTime {
        /// The item.
        item: String,
        /// The time as written.
        time: String,
    },
    /// An unplugging window that ends before it starts, or overlaps another.
    #[error("fault `{item}`: {reason}")]
    BadWindow {
        /// The item.
        item: String,
        /// What is wrong.
        reason: String,
    },
}

impl LineFault {
    /// Reads one item of a list.
    ///
    /// # Errors
    /// When the item is no line fault, or its number or times cannot be read.
    pub fn parse(item: &str) -> Result<Self, LineFaultError> {
        if let Some(window) = item.strip_prefix("unplug@") {
            return parse_window(item, window).map(Self::Unplug);
        }
        let (key, value) = match item.split_once('=') {
            Some((key, value)) => (key.trim(), Some(value.trim())),
            None => (item, None),
        };
        let count = |value: Option<&str>| -> Result<u32, LineFaultError> {
            value
                .and_then(|value| value.parse().ok())
                .ok_or_else(|| LineFaultError::BadCount {
                    item: item.to_owned(),
                })
        };
        match (key, value) {
            ("noise", value) => Ok(Self::Noise(count(value)?)),
            ("bad-crc-every", value) => Ok(Self::BadCrcEvery(count(value)?)),
            ("silent", None) => Ok(Self::Silent),
            ("none", None) => Ok(Self::None),
            _ => Err(LineFaultError::Unknown {
                item: item.to_owned(),
                // `unplg@1s` is near `unplug`, `silnt` near `silent`.
                suggestion: lewis_stdx::closest(key.split('@').next().unwrap_or(key), Self::WORDS)
                    .filter(|&word| word != key),
            }),
        }
    }
}

/// Reads a line fault list: comma-separated items, later ones overriding earlier ones,
/// except `unplug@`, which adds a window each time (windows may not overlap).
///
/// # Errors
/// The first item that is not a fault, or whose number or times cannot be read.
pub fn parse_line_faults(spec: &str) -> Result<LineFaultPlan, LineFaultError> {
    let mut plan = LineFaultPlan::default();
    for item in spec
        .split(',')
        .map(str::trim)
        .filter(|item| !item.is_empty())
    {
        match LineFault::parse(item)? {
            LineFault::Noise(count) => plan.faults.noise_bytes = count as usize,
            LineFault::BadCrcEvery(every) => plan.faults.corrupt_checksum_every = every,
            LineFault::Silent => plan.faults.silent = true,
            LineFault::Unplug(unplug) => plan.unplugs.push(unplug),
            LineFault::None => plan = LineFaultPlan::default(),
        }
    }
    plan.unplugs.sort_by_key(|unplug| unplug.at);
    for pair in plan.unplugs.windows(2) {
        if pair[0].until.is_none_or(|until| until > pair[1].at) {
            return Err(LineFaultError::BadWindow {
                item: format!("unplug@{}", show(pair[1].at)),
                reason: format!(
                    "it starts while the cable is still out since {}: unplugging windows may not overlap",
                    show(pair[0].at)
                ),
            });
        }
    }
    Ok(plan)
}

/// `T1-T2` or `T1`.
fn parse_window(item: &str, window: &str) -> Result<Unplug, LineFaultError> {
    let (at, until) = match window.split_once('-') {
        Some((at, until)) => (at, Some(until)),
        None => (window, None),
    };
    let at = parse_time(item, at)?;
    let until = until.map(|until| parse_time(item, until)).transpose()?;
    if let Some(until) = until
        && until <= at
    {
        return Err(LineFaultError::BadWindow {
            item: item.to_owned(),
            reason: "the cable must be put back after it is pulled: write unplug@T1-T2 with T2 later than T1".to_owned(),
        });
    }
    Ok(Unplug { at, until })
}

/// `5s`, `1.5s`, `500ms`: a time as written everywhere in Lewis ([`lewis_stdx`]), of at most
/// a day.
fn parse_time(item: &str, text: &str) -> Result<Duration, LineFaultError> {
    let text = text.trim();
    let bad = || LineFaultError::BadTime {
        item: item.to_owned(),
        time: text.to_owned(),
    };
    let time = lewis_stdx::parse_duration(text).map_err(|_| bad())?;
    if time > Duration::from_secs(86_400) {
        return Err(bad());
    }
    Ok(time)
}

fn show(time: Duration) -> String {
    format!("{}s", time.as_secs_f64())
}

/// What a `frozen` fault publishes: the last good payload with the header of the new one
/// (its sequence number and publish time), as a stuck device's driver sends it; the last payload as it was when the two
/// headers differ in length.
pub fn frozen_payload(last: &[u8], new: &[u8]) -> Vec<u8> {
    let mut out = last.to_vec();
    if let Ok(header) = cdr::peek_header(new) {
        let _ = cdr::replace_header(&mut out, &header);
    }
    out
}

/// What a `garbage` fault publishes: bytes that do not decode, of the given length, the same for the same provider and
/// sequence number.
pub fn garbled_payload(provider: &str, seq: u64, len: usize) -> Vec<u8> {
    let mut rng = crate::Rng::new(crate::Rng::seed_from_name(provider) ^ seq);
    let mut out = cdr::ENCAPSULATION_LE.to_vec();
    while out.len() < len.max(cdr::ENCAPSULATION_LE.len() + 4) {
        out.extend_from_slice(&rng.next_u64().to_le_bytes());
    }
    // A provider string longer than the message: no decoder accepts it.
    out[4..8].copy_from_slice(&u32::MAX.to_le_bytes());
    out.truncate(len.max(cdr::ENCAPSULATION_LE.len() + 4));
    out
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn every_place_takes_its_words_and_names_them_when_refusing() {
        assert_eq!(LIVE_FAULTS.parse("stall"), Ok(Some(ServiceFault::Stall)));
        assert_eq!(LIVE_FAULTS.parse("clear"), Ok(None));
        assert_eq!(
            LIVE_FAULTS.parse("explode").unwrap_err().to_string(),
            "unknown fault `explode`: expected stall, out-of-service, frozen, garbage or clear"
        );
        assert_eq!(
            LIVE_FAULTS.parse("stal").unwrap_err().to_string(),
            "unknown fault `stal`: expected stall, out-of-service, frozen, garbage or clear; did you mean `stall`?"
        );
        // A fault of a service that this place cannot make is refused like any other word.
        assert!(LIVE_FAULTS.parse("crash").is_err());
        assert_eq!(
            REPLAY_FAULTS.names(),
            "crash, stall, garbage, frozen, slow, out-of-service, stuck, host-lost"
        );
        assert_eq!(
            FAULT_FILE_FAULTS.listed(),
            "ok, degraded, out-of-service, stall, crash, garbage, nan, frozen or slow"
        );
        assert_eq!(FAULT_FILE_FAULTS.parse("ok"), Ok(None));
        assert_eq!(FAULT_FILE_FAULTS.parse("nan"), Ok(Some(ServiceFault::Nan)));
    }

    #[test]
    fn a_word_means_the_same_fault_wherever_it_is_taken() {
        for words in [LIVE_FAULTS, REPLAY_FAULTS, FAULT_FILE_FAULTS] {
            for &fault in words.faults {
                assert_eq!(words.parse(words.word(fault)), Ok(fault));
            }
        }
        for fault in ServiceFault::ALL {
            let json = serde_json_word(fault);
            assert_eq!(json, fault.word());
        }
    }

    /// What serde writes for a fault (replay's reports hold it): its word.
    fn serde_json_word(fault: ServiceFault) -> String {
        toml::Value::try_from(std::collections::BTreeMap::from([("k", fault)]))
            .unwrap()
            .get("k")
            .and_then(|v| v.as_str().map(str::to_owned))
            .unwrap()
    }

    #[test]
    fn line_fault_items_suggest_the_word_meant() {
        let e = parse_line_faults("silnt").unwrap_err().to_string();
        assert!(
            e.ends_with("comma-separated; did you mean `silent`?"),
            "{e}"
        );
        let e = parse_line_faults("unplg@1s").unwrap_err().to_string();
        assert!(
            e.contains("unplug@T1-T2") && e.ends_with("`unplug`?"),
            "{e}"
        );
        let e = parse_line_faults("silent=1").unwrap_err().to_string();
        assert!(!e.contains("did you mean"), "{e}");
        assert_eq!(
            parse_line_faults("noise=3,none,bad-crc-every=2"),
            Ok(LineFaultPlan {
                faults: LineFaults {
                    corrupt_checksum_every: 2,
                    ..LineFaults::default()
                },
                unplugs: Vec::new(),
            })
        );
    }
}
