//! Health from the data: the checks of what one provider publishes on one interface
//! against what the interface and the robot file promise (rate, freshness, values, a frozen
//! stream). Pure, like the decision core beside it: no IPC and no clock; the caller feeds
//! each sample's publish time and bytes with its own `now`, and asks again when time passes
//! without samples ([`DataMonitor::poll`], due at [`DataMonitor::deadline`]). The same
//! samples at the same times give the same verdicts, live and in replay.
//!
//! A monitor judges one run of a provider: it is built when the provider becomes ready and
//! dropped when it stops, so a restarted provider starts with a clean slate (the rate is
//! judged only a window after the start).

mod values;

#[cfg(test)]
mod proptests;
#[cfg(test)]
mod tests;

use std::collections::VecDeque;
use std::fmt;
use std::hash::{DefaultHasher, Hasher};

use lewis_interfaces::cdr;

use lewis_robot::{DataChecks, OnCheckFailure};

use values::ValueCheck;

/// The data checks, by name: what a failure names as its cause.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Check {
    /// Fewer samples over the window than a fraction of the declared rate.
    Rate,
    /// A sample published too long before it was seen.
    Freshness,
    /// A payload that breaks its interface's promises (decoding, numbers, sizes, ranges).
    Values,
    /// Identical payloads in a row.
    Frozen,
}

impl Check {
    /// Every check, in the order they are documented.
    pub const ALL: [Self; 4] = [Self::Rate, Self::Freshness, Self::Values, Self::Frozen];

    /// Its name, as the robot file's `checks` and the broker's reasons write it.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Rate => "rate",
            Self::Freshness => "freshness",
            Self::Values => "values",
            Self::Frozen => "frozen",
        }
    }

    /// The check with this name.
    #[must_use]
    pub fn parse(name: &str) -> Option<Self> {
        Self::ALL.into_iter().find(|c| c.as_str() == name)
    }
}

impl fmt::Display for Check {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A failed check: which one, and what it saw.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CheckFailure {
    /// The check that fired.
    pub check: Check,
    /// What it saw, for people (`ranges[3] is NaN, not a finite number`).
    pub reason: String,
    /// Whether the provider is to be failed or only degraded.
    pub on_failure: OnCheckFailure,
}

impl fmt::Display for CheckFailure {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{} check failed: {}", self.check, self.reason)
    }
}

/// The data checks of one provider's channel of one interface.
#[derive(Debug, Clone)]
pub struct DataMonitor {
    interface: String,
    checks: DataChecks,
    window_ns: i64,
    /// Samples the rate check needs within a window; 0 when it is off.
    needed: usize,
    rate_hz: f64,
    started_ns: i64,
    /// The arrival times of the last `needed` samples (bounded by `needed`).
    arrivals: VecDeque<i64>,
    values: Option<ValueCheck>,
    /// The hash of the last payload (header aside) and how many in a row had it.
    last_body: Option<u64>,
    repeats: u32,
}

impl DataMonitor {
    /// A monitor of a provider of `interface` that declares `data_rate_hz` (the rate check
    /// applies only when it does), watched from `now_ns`.
    #[must_use]
    pub fn new(
        interface: &str,
        checks: DataChecks,
        data_rate_hz: Option<f64>,
        now_ns: i64,
    ) -> Self {
        let rate_hz = data_rate_hz
            .filter(|hz| hz.is_finite() && *hz > 0.0)
            .unwrap_or(0.0);
        // At least four periods: a 1 Hz battery reading is not judged on one sample's jitter.
        let periods_ms = if rate_hz > 0.0 {
            (4_000.0 / rate_hz).ceil() as u64
        } else {
            0
        };
        let window_ms = checks.window_ms.max(periods_ms);
        let window_ns = i64::try_from(window_ms.saturating_mul(1_000_000)).unwrap_or(i64::MAX);
        let expected = rate_hz * checks.min_rate_fraction * (window_ms as f64 / 1000.0);
        // At least one sample once on; bounded, so the window's queue is too.
        let needed = if expected > 0.0 {
            (expected.ceil() as usize).clamp(1, 1 << 16)
        } else {
            0
        };
        Self {
            interface: interface.to_owned(),
            checks,
            window_ns,
            needed,
            rate_hz,
            started_ns: now_ns,
            arrivals: VecDeque::with_capacity(needed.min(1024)),
            values: checks.values.then(|| ValueCheck::new(interface)),
            last_body: None,
            repeats: 0,
        }
    }

    /// The interface it watches.
    #[must_use]
    pub fn interface(&self) -> &str {
        &self.interface
    }

    /// Judges one sample seen at `now_ns`, published at `publish_ns` (its header's time),
    /// then the rate so far.
    ///
    /// # Errors
    /// The first check that fails, in the order freshness, values, frozen, rate.
    pub fn sample(
        &mut self,
        now_ns: i64,
        publish_ns: i64,
        bytes: &[u8],
    ) -> Result<(), CheckFailure> {
        if self.needed > 0 {
            if self.arrivals.len() == self.needed {
                self.arrivals.pop_front();
            }
            // Counted when it was published (no later than now, never before the last one):
            // a watcher that reads late, its loop held up, still counts the samples in time.
            let last = self.arrivals.back().copied().unwrap_or(i64::MIN);
            self.arrivals.push_back(publish_ns.min(now_ns).max(last));
        }
        if let Some(limit_ms) = self.checks.freshness_ms {
            let age_ns = now_ns.saturating_sub(publish_ns);
            if age_ns > i64::try_from(limit_ms.saturating_mul(1_000_000)).unwrap_or(i64::MAX) {
                return Err(self.failure(
                    Check::Freshness,
                    format!(
                        "a sample published {} ms before it was seen, more than {limit_ms} ms",
                        age_ns / 1_000_000
                    ),
                ));
            }
        }
        if let Some(values) = &self.values
            && let Err(what) = values.check(bytes)
        {
            return Err(self.failure(Check::Values, what));
        }
        if let Some(count) = self.checks.frozen_count {
            let body = body_hash(bytes);
            if self.last_body == Some(body) {
                self.repeats = self.repeats.saturating_add(1);
            } else {
                self.last_body = Some(body);
                self.repeats = 1;
            }
            if self.repeats >= count {
                return Err(self.failure(
                    Check::Frozen,
                    format!("{count} identical payloads in a row: the data is frozen"),
                ));
            }
        }
        self.poll(now_ns)
    }

    /// Judges the rate at `now_ns`, with or without new samples.
    ///
    /// # Errors
    /// A rate failure when fewer samples than the check needs arrived in the last window.
    pub fn poll(&mut self, now_ns: i64) -> Result<(), CheckFailure> {
        match self.deadline() {
            Some(due) if now_ns >= due => {
                let window_ms = self.window_ns / 1_000_000;
                let seen = self
                    .arrivals
                    .iter()
                    .filter(|t| **t > now_ns.saturating_sub(self.window_ns))
                    .count();
                Err(self.failure(
                    Check::Rate,
                    format!(
                        "{seen} samples in {window_ms} ms, fewer than {} ({} of {} Hz)",
                        self.needed, self.checks.min_rate_fraction, self.rate_hz
                    ),
                ))
            }
            _ => Ok(()),
        }
    }

    /// Judges the rate afresh from `now_ns`, a window later: what the watcher could not
    /// read meanwhile (its own loop held up, its buffer overflowed) is not the provider's
    /// fault.
    pub fn restart_rate(&mut self, now_ns: i64) {
        self.started_ns = now_ns;
        self.arrivals.clear();
    }

    /// When the rate check fails if no sample comes before: `None` when it is off.
    #[must_use]
    pub fn deadline(&self) -> Option<i64> {
        if self.needed == 0 {
            return None;
        }
        let judged_from = self.started_ns.saturating_add(self.window_ns);
        let due = if self.arrivals.len() < self.needed {
            judged_from
        } else {
            // The oldest of the last `needed` samples leaves the window then.
            self.arrivals
                .front()
                .map_or(judged_from, |t| t.saturating_add(self.window_ns))
                .max(judged_from)
        };
        Some(due)
    }

    fn failure(&self, check: Check, reason: String) -> CheckFailure {
        CheckFailure {
            check,
            reason,
            on_failure: self.checks.on_failure,
        }
    }
}

/// A hash of the payload after its header (which differs in every sample by its sequence
/// number and time), or of all the bytes when they have no header.
fn body_hash(bytes: &[u8]) -> u64 {
    let body = cdr::peek_header(bytes)
        .ok()
        .and_then(|header| bytes.get(cdr::encoded_len(&header)..))
        .unwrap_or(bytes);
    // SipHash with fixed keys: the same bytes hash the same in every process and run.
    let mut hasher = DefaultHasher::new();
    hasher.write(body);
    hasher.finish()
}
