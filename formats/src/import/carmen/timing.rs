//! The time policy of the CARMEN importer: a pure function from the timestamps printed in a
//! log, in file order, to times that never go backwards, and a report of what was wrong and
//! what was done about it.
//!
//! Real CARMEN logs have broken clocks: stamps that go backwards, that are zero, negative,
//! or printed with `%g` so coarsely (`1.13486e+09`) that they cannot order scans. The policy:
//!
//! 1. **The file order is the truth** of what happened first: the logger wrote lines as they
//!    arrived. A stamp is only a claim about *when*.
//! 2. **The laser is the clock.** Scan stamps are judged on their own: a stamp is *usable*
//!    when it is finite, positive, at most about 146 years (so it fits in nanoseconds with
//!    room to spare) and printed finely enough ([`TimingOptions::coarsest_resolution_s`]).
//!    Of the usable ones, the longest run that never goes backwards in file order is kept
//!    (a longest non-decreasing subsequence, so one wild stamp costs one stamp, not the rest
//!    of the log); the others are *out of order*.
//! 3. Scans without a kept stamp are **re-timed**: linearly between the kept scans around them
//!    (by scan count), and before the first or after the last kept one by the scan period.
//!    The scan period is the median interval between consecutive kept scans when there are at
//!    least [`MIN_MEASURED_INTERVALS`] of them, else [`TimingOptions::nominal_scan_period_ns`].
//!    A log without a single usable scan stamp has scan `k` at `(k + 1)` periods (one
//!    period of room before the first scan for the odometry logged before it).
//! 4. **Odometry fits between the scans.** An odometry stamp is kept when it is usable, lies
//!    between the (re-timed) scans written before and after it, and belongs to the longest
//!    non-decreasing run of such stamps in that gap; the others are spread evenly between
//!    their kept neighbours. (In the "corrected" Radish logs every scan is followed by an
//!    odometry line stamped 0 or with uninitialised memory; this is where they land.)
//! 5. **Strictly increasing.** A time not later than the one before it (a tie) is moved to
//!    one nanosecond after it, in file order, and counted.
//!
//! With [`TimePolicy::RejectBrokenScans`], a log with any unusable scan stamp is refused
//! instead (odometry is still re-timed: its stamps are secondary).

use std::fmt;

/// At least this many intervals between consecutive kept scan stamps are needed to measure
/// the scan period; with fewer, the nominal period is used.
pub const MIN_MEASURED_INTERVALS: usize = 3;

/// Stamps beyond this many seconds are out of range (2^62 ns, about 146 years): they are
/// garbage, and refusing them leaves room for arithmetic on nanoseconds.
pub const MAX_STAMP_S: f64 = 4_611_686_018.0;

/// Which stream of the log a timestamp belongs to.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum Stream {
    /// A laser scan (FLASER, ROBOTLASER1): the clock of the import.
    Scan,
    /// An odometry reading (ODOM).
    Odometry,
}

impl Stream {
    fn label(self) -> &'static str {
        match self {
            Self::Scan => "laser scan",
            Self::Odometry => "odometry",
        }
    }
}

/// A timestamp as printed in the log: its value and the finest step its text can express.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct PrintedTime {
    /// The value, in seconds (may be NaN, infinite, zero or negative: the log says so).
    pub seconds: f64,
    /// The step of the last significant digit, in seconds: `1.13486e+09` has 10 000 s,
    /// `839.275` has 0.001 s.
    pub resolution_s: f64,
}

impl PrintedTime {
    /// Reads a timestamp as printed by CARMEN (`%f`, `%g` or an exponent), or `None` when the
    /// text is not a number.
    ///
    /// CARMEN prints with `%g`, which drops trailing zeros: `1061.5` is 1061.50 to six
    /// significant digits. So the resolution is the finer of the last printed digit and the
    /// sixth significant digit.
    #[must_use]
    pub fn parse(text: &str) -> Option<Self> {
        let seconds: f64 = text.parse().ok()?;
        let (mantissa, exponent) = match text.find(['e', 'E']) {
            Some(at) => (&text[..at], text[at + 1..].parse::<i32>().unwrap_or(0)),
            None => (text, 0),
        };
        let decimals = mantissa
            .split_once('.')
            .map_or(0, |(_, digits)| digits.len());
        let decimals = i32::try_from(decimals).unwrap_or(i32::MAX);
        let last_digit = 10f64.powi(exponent.saturating_sub(decimals));
        let resolution_s = if seconds.is_finite() && seconds != 0.0 {
            // log10 of a finite f64 is within ±330
            let magnitude = seconds.abs().log10().floor() as i32;
            last_digit.min(10f64.powi(magnitude - 5))
        } else {
            last_digit
        };
        Some(Self {
            seconds,
            resolution_s,
        })
    }
}

/// One timestamped record of the log, in file order.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct StampInput {
    /// Scan or odometry.
    pub stream: Stream,
    /// The line of the log it came from (for the report).
    pub line: u64,
    /// The logger timestamp printed on that line; `None` when the line carries none.
    pub time: Option<PrintedTime>,
}

/// What to do about broken timestamps.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub enum TimePolicy {
    /// Re-time what is broken and say so in the report.
    #[default]
    Retime,
    /// Refuse a log with any unusable scan timestamp.
    RejectBrokenScans,
}

/// Parameters of the time policy.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct TimingOptions {
    /// Re-time or reject.
    pub policy: TimePolicy,
    /// The scan period used when it cannot be measured from the log, in ns.
    pub nominal_scan_period_ns: i64,
    /// Stamps printed more coarsely than this (in seconds) cannot order scans and are
    /// unusable.
    pub coarsest_resolution_s: f64,
}

impl Default for TimingOptions {
    /// Re-time; a nominal 5 Hz scanner (the SICK LMS of the Radish logs streamed at 4 to
    /// 5 Hz over 38400 baud); stamps must be printed to 0.1 s.
    fn default() -> Self {
        Self {
            policy: TimePolicy::Retime,
            nominal_scan_period_ns: 200_000_000,
            coarsest_resolution_s: 0.1,
        }
    }
}

/// What was wrong with one stamp.
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub enum StampProblem {
    /// The line carries no timestamp.
    Missing,
    /// NaN or infinite.
    NotFinite,
    /// Exactly zero.
    Zero,
    /// Below zero.
    Negative,
    /// Beyond [`MAX_STAMP_S`].
    OutOfRange,
    /// Printed too coarsely to order scans (`1.13486e+09`).
    Coarse,
    /// Usable on its own but against the file order (the clock went backwards, or the stamp
    /// lies outside the scans around it).
    OutOfOrder,
}

impl fmt::Display for StampProblem {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(match self {
            Self::Missing => "missing",
            Self::NotFinite => "not finite",
            Self::Zero => "zero",
            Self::Negative => "negative",
            Self::OutOfRange => "out of range",
            Self::Coarse => "printed too coarsely",
            Self::OutOfOrder => "out of order",
        })
    }
}

/// The timestamps of one stream: how many, how many kept, and each problem's count.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default)]
pub struct StreamTiming {
    /// Records of this stream.
    pub total: usize,
    /// Records whose own stamp was kept.
    pub kept: usize,
    /// Lines without a timestamp.
    pub missing: usize,
    /// NaN or infinite stamps.
    pub not_finite: usize,
    /// Stamps equal to zero.
    pub zero: usize,
    /// Negative stamps.
    pub negative: usize,
    /// Stamps beyond [`MAX_STAMP_S`].
    pub out_of_range: usize,
    /// Stamps printed too coarsely.
    pub coarse: usize,
    /// Usable stamps against the file order.
    pub out_of_order: usize,
    /// The line of the first problem, and which problem it was.
    pub first_problem: Option<(u64, StampProblem)>,
}

impl StreamTiming {
    /// Records that were given a new time.
    #[must_use]
    pub fn retimed(&self) -> usize {
        self.total - self.kept
    }

    /// The count of one problem.
    #[must_use]
    pub fn count(&self, problem: StampProblem) -> usize {
        match problem {
            StampProblem::Missing => self.missing,
            StampProblem::NotFinite => self.not_finite,
            StampProblem::Zero => self.zero,
            StampProblem::Negative => self.negative,
            StampProblem::OutOfRange => self.out_of_range,
            StampProblem::Coarse => self.coarse,
            StampProblem::OutOfOrder => self.out_of_order,
        }
    }

    fn note(&mut self, line: u64, problem: StampProblem) {
        let counter = match problem {
            StampProblem::Missing => &mut self.missing,
            StampProblem::NotFinite => &mut self.not_finite,
            StampProblem::Zero => &mut self.zero,
            StampProblem::Negative => &mut self.negative,
            StampProblem::OutOfRange => &mut self.out_of_range,
            StampProblem::Coarse => &mut self.coarse,
            StampProblem::OutOfOrder => &mut self.out_of_order,
        };
        *counter += 1;
        if self.first_problem.is_none_or(|(first, _)| line < first) {
            self.first_problem = Some((line, problem));
        }
    }

    fn problems(&self) -> Vec<String> {
        const ALL: [StampProblem; 7] = [
            StampProblem::Missing,
            StampProblem::NotFinite,
            StampProblem::Zero,
            StampProblem::Negative,
            StampProblem::OutOfRange,
            StampProblem::Coarse,
            StampProblem::OutOfOrder,
        ];
        ALL.iter()
            .filter(|p| self.count(**p) > 0)
            .map(|p| format!("{} {p}", self.count(*p)))
            .collect()
    }
}

/// Where the scan period used for re-timing came from.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum PeriodSource {
    /// The median of this many intervals between consecutive kept scan stamps.
    Measured {
        /// How many intervals it was measured from.
        intervals: usize,
    },
    /// [`TimingOptions::nominal_scan_period_ns`]: too few usable scan stamps to measure it.
    Nominal,
}

/// What the time policy found and did.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct TimingReport {
    /// The scans' stamps.
    pub scans: StreamTiming,
    /// The odometry's stamps.
    pub odometry: StreamTiming,
    /// The scan period used to re-time, in ns.
    pub scan_period_ns: i64,
    /// Where it came from.
    pub scan_period_source: PeriodSource,
    /// Times moved 1 ns after the one before them to keep time strictly increasing.
    pub ties_separated: usize,
    /// The first output time, in ns (0 for an empty log).
    pub start_ns: i64,
    /// The last output time, in ns (0 for an empty log).
    pub end_ns: i64,
}

impl TimingReport {
    /// Whether every stamp was kept as printed (nothing re-timed, no tie moved).
    #[must_use]
    pub fn is_clean(&self) -> bool {
        self.scans.retimed() == 0 && self.odometry.retimed() == 0 && self.ties_separated == 0
    }

    /// One sentence per thing the user should know: what was wrong and what was done.
    #[must_use]
    pub fn warnings(&self) -> Vec<String> {
        let mut out = Vec::new();
        let period_ms = self.scan_period_ns as f64 / 1e6;
        let period = match self.scan_period_source {
            PeriodSource::Measured { intervals } => {
                format!("{period_ms:.1} ms, measured from {intervals} intervals")
            }
            PeriodSource::Nominal => format!("{period_ms:.1} ms, nominal"),
        };
        for (stream, timing) in [
            (Stream::Scan, &self.scans),
            (Stream::Odometry, &self.odometry),
        ] {
            if timing.retimed() == 0 {
                continue;
            }
            let first = timing
                .first_problem
                .map(|(line, problem)| format!("; the first, {problem}, at line {line}"))
                .unwrap_or_default();
            let how = match (stream, timing.kept) {
                (Stream::Scan, 0) => format!("all re-timed from the scan period ({period})"),
                (Stream::Scan, _) => format!(
                    "re-timed between the kept scan stamps, and from the scan period ({period}) before the first or after the last"
                ),
                (Stream::Odometry, _) => {
                    "re-timed evenly between the scans and kept odometry stamps around them"
                        .to_owned()
                }
            };
            out.push(format!(
                "{} timestamps: {} of {} unusable ({}{first}): {how}",
                stream.label(),
                timing.retimed(),
                timing.total,
                timing.problems().join(", "),
            ));
        }
        if self.ties_separated > 0 {
            out.push(format!(
                "{} records had the same time as the record before them (often a scan and the odometry logged with it): each was moved 1 ns after it, in file order, so that time strictly increases",
                self.ties_separated
            ));
        }
        out
    }
}

/// The output of the time policy.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Retimed {
    /// One time per input, in ns, in input order: never negative, strictly increasing.
    pub times_ns: Vec<i64>,
    /// What was found and done.
    pub report: TimingReport,
}

/// Why the time policy refused a log.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum TimingError {
    /// [`TimePolicy::RejectBrokenScans`] and some scan stamps are unusable.
    #[error(
        "{} of {} laser scan timestamps are unusable ({}{}): import with re-timing to give them times from the scan rate",
        .0.scans.retimed(),
        .0.scans.total,
        .0.scans.problems().join(", "),
        .0.scans.first_problem.map(|(line, p)| format!("; the first, {p}, at line {line}")).unwrap_or_default()
    )]
    BrokenScanTimes(Box<TimingReport>),
}

enum Class {
    Usable(i64),
    Bad(StampProblem),
}

fn classify(time: Option<PrintedTime>, coarsest_resolution_s: f64) -> Class {
    let Some(t) = time else {
        return Class::Bad(StampProblem::Missing);
    };
    let s = t.seconds;
    if !s.is_finite() {
        Class::Bad(StampProblem::NotFinite)
    } else if s == 0.0 {
        Class::Bad(StampProblem::Zero)
    } else if s < 0.0 {
        Class::Bad(StampProblem::Negative)
    } else if s > MAX_STAMP_S {
        Class::Bad(StampProblem::OutOfRange)
    } else if t.resolution_s > coarsest_resolution_s {
        Class::Bad(StampProblem::Coarse)
    } else {
        // bounded by MAX_STAMP_S above
        Class::Usable((s * 1e9).round() as i64)
    }
}

/// Re-times a log's stamps (see the module documentation for the policy).
///
/// # Errors
/// [`TimingError::BrokenScanTimes`] under [`TimePolicy::RejectBrokenScans`] when a scan
/// stamp is unusable.
pub fn retime(inputs: &[StampInput], options: &TimingOptions) -> Result<Retimed, TimingError> {
    let nominal = options.nominal_scan_period_ns.max(1);
    let classes: Vec<Class> = inputs
        .iter()
        .map(|i| classify(i.time, options.coarsest_resolution_s))
        .collect();
    let mut scans = StreamTiming::default();
    let mut odometry = StreamTiming::default();
    for (input, class) in inputs.iter().zip(&classes) {
        let timing = match input.stream {
            Stream::Scan => &mut scans,
            Stream::Odometry => &mut odometry,
        };
        timing.total += 1;
        if let Class::Bad(problem) = class {
            timing.note(input.line, *problem);
        }
    }

    // The scans, on their own.
    let scan_at: Vec<usize> = (0..inputs.len())
        .filter(|&i| inputs[i].stream == Stream::Scan)
        .collect();
    let (candidates, values): (Vec<usize>, Vec<i64>) = scan_at
        .iter()
        .enumerate()
        .filter_map(|(k, &i)| match classes[i] {
            Class::Usable(t) => Some((k, t)),
            Class::Bad(_) => None,
        })
        .unzip();
    let mut scan_anchor: Vec<Option<i64>> = vec![None; scan_at.len()];
    for ((&k, &t), keep) in candidates
        .iter()
        .zip(&values)
        .zip(longest_non_decreasing(&values))
    {
        if keep {
            scan_anchor[k] = Some(t);
            scans.kept += 1;
        } else {
            scans.note(inputs[scan_at[k]].line, StampProblem::OutOfOrder);
        }
    }
    let mut intervals: Vec<i64> = scan_anchor
        .windows(2)
        .filter_map(|w| match (w[0], w[1]) {
            (Some(a), Some(b)) if b > a => Some(b - a),
            _ => None,
        })
        .collect();
    let (scan_period_ns, scan_period_source) = if intervals.len() >= MIN_MEASURED_INTERVALS {
        intervals.sort_unstable();
        (
            intervals[intervals.len() / 2],
            PeriodSource::Measured {
                intervals: intervals.len(),
            },
        )
    } else {
        (nominal, PeriodSource::Nominal)
    };
    let scan_times = fill(&scan_anchor, scan_period_ns);

    // Odometry, gap by gap between consecutive scans.
    let mut times = vec![0i64; inputs.len()];
    for (k, &i) in scan_at.iter().enumerate() {
        times[i] = scan_times[k];
    }
    let mut start = 0;
    let mut scans_before: usize = 0;
    while start < inputs.len() {
        if inputs[start].stream == Stream::Scan {
            scans_before += 1;
            start += 1;
            continue;
        }
        let end = (start..inputs.len())
            .find(|&i| inputs[i].stream == Stream::Scan)
            .unwrap_or(inputs.len());
        let left = scans_before.checked_sub(1).map(|k| scan_times[k]);
        let right = scan_times.get(scans_before).copied();
        let step = if scan_at.is_empty() {
            scan_period_ns
        } else {
            let slots = i64::try_from(end - start + 1).unwrap_or(i64::MAX);
            (scan_period_ns / slots).max(1)
        };
        let gap = GapInputs {
            inputs: &inputs[start..end],
            classes: &classes[start..end],
            left,
            right,
            step,
        };
        let filled = retime_gap(&gap, &mut odometry);
        times[start..end].copy_from_slice(&filled);
        start = end;
    }

    let mut ties_separated = 0;
    for i in 1..times.len() {
        if times[i] <= times[i - 1] {
            times[i] = times[i - 1].saturating_add(1);
            ties_separated += 1;
        }
    }
    let report = TimingReport {
        scans,
        odometry,
        scan_period_ns,
        scan_period_source,
        ties_separated,
        start_ns: times.first().copied().unwrap_or(0),
        end_ns: times.last().copied().unwrap_or(0),
    };
    if options.policy == TimePolicy::RejectBrokenScans && report.scans.retimed() > 0 {
        return Err(TimingError::BrokenScanTimes(Box::new(report)));
    }
    Ok(Retimed {
        times_ns: times,
        report,
    })
}

struct GapInputs<'a> {
    inputs: &'a [StampInput],
    classes: &'a [Class],
    left: Option<i64>,
    right: Option<i64>,
    step: i64,
}

/// The times of a run of odometry records between two scans (either may be absent).
fn retime_gap(gap: &GapInputs<'_>, report: &mut StreamTiming) -> Vec<i64> {
    let inside = |t: i64| gap.left.is_none_or(|l| t >= l) && gap.right.is_none_or(|r| t <= r);
    let mut candidates = Vec::new();
    let mut values = Vec::new();
    for (j, (input, class)) in gap.inputs.iter().zip(gap.classes).enumerate() {
        if let Class::Usable(t) = *class {
            if inside(t) {
                candidates.push(j);
                values.push(t);
            } else {
                report.note(input.line, StampProblem::OutOfOrder);
            }
        }
    }
    // Slot 0 is the scan before, slot m + 1 the scan after.
    let m = gap.inputs.len();
    let mut anchors: Vec<Option<i64>> = vec![None; m + 2];
    anchors[0] = gap.left;
    anchors[m + 1] = gap.right;
    for ((&j, &t), keep) in candidates
        .iter()
        .zip(&values)
        .zip(longest_non_decreasing(&values))
    {
        if keep {
            anchors[j + 1] = Some(t);
            report.kept += 1;
        } else {
            report.note(gap.inputs[j].line, StampProblem::OutOfOrder);
        }
    }
    let filled = fill(&anchors, gap.step);
    filled[1..=m].to_vec()
}

/// Times for evenly spaced slots: the anchors where given, linear between anchors,
/// `step_ns` per slot before the first and after the last, never below zero. Without any
/// anchor, slot `k` is at `(k + 1) * step_ns`.
fn fill(anchors: &[Option<i64>], step_ns: i64) -> Vec<i64> {
    let known: Vec<(usize, i64)> = anchors
        .iter()
        .enumerate()
        .filter_map(|(k, a)| a.map(|t| (k, t)))
        .collect();
    let slot = |k: usize| i64::try_from(k).unwrap_or(i64::MAX);
    let Some((&(first_k, first_t), &(last_k, last_t))) = known.first().zip(known.last()) else {
        return (1..=anchors.len())
            .map(|k| slot(k).saturating_mul(step_ns))
            .collect();
    };
    let mut out = Vec::with_capacity(anchors.len());
    let mut next = 0; // index into `known` of the first anchor at or after k
    for k in 0..anchors.len() {
        while next < known.len() && known[next].0 < k {
            next += 1;
        }
        let t = if k < first_k {
            first_t.saturating_sub(slot(first_k - k).saturating_mul(step_ns))
        } else if k > last_k {
            last_t.saturating_add(slot(k - last_k).saturating_mul(step_ns))
        } else if known[next].0 == k {
            known[next].1
        } else {
            let (a_k, a_t) = known[next - 1];
            let (b_k, b_t) = known[next];
            let span = i128::from(b_t) - i128::from(a_t);
            let offset = span * (k - a_k) as i128 / (b_k - a_k) as i128;
            i64::try_from(i128::from(a_t) + offset).unwrap_or(a_t)
        };
        out.push(t.max(0));
    }
    out
}

/// Which of `values` form a longest non-decreasing subsequence (the same one every time).
fn longest_non_decreasing(values: &[i64]) -> Vec<bool> {
    let mut tail_value: Vec<i64> = Vec::new();
    let mut tail_index: Vec<usize> = Vec::new();
    let mut previous: Vec<Option<usize>> = Vec::with_capacity(values.len());
    for (i, &v) in values.iter().enumerate() {
        let k = tail_value.partition_point(|&t| t <= v);
        previous.push(k.checked_sub(1).map(|p| tail_index[p]));
        if k == tail_value.len() {
            tail_value.push(v);
            tail_index.push(i);
        } else {
            tail_value[k] = v;
            tail_index[k] = i;
        }
    }
    let mut keep = vec![false; values.len()];
    let mut at = tail_index.last().copied();
    while let Some(i) = at {
        keep[i] = true;
        at = previous[i];
    }
    keep
}

#[cfg(test)]
mod tests {
    #![allow(clippy::unwrap_used)]

    use super::*;

    /// `log` is `S` or `O` followed by a printed time (`-` for none), one per record.
    fn inputs(log: &[&str]) -> Vec<StampInput> {
        log.iter()
            .zip(1..)
            .map(|(entry, line)| {
                let (kind, text) = entry.split_at(1);
                StampInput {
                    stream: if kind == "S" {
                        Stream::Scan
                    } else {
                        Stream::Odometry
                    },
                    line,
                    time: if text == "-" {
                        None
                    } else {
                        Some(PrintedTime::parse(text).unwrap())
                    },
                }
            })
            .collect()
    }

    fn check(log: &[&str], expected_ms: &[i64]) -> TimingReport {
        let out = retime(&inputs(log), &TimingOptions::default()).unwrap();
        let ms: Vec<i64> = out.times_ns.iter().map(|t| t / 1_000_000).collect();
        assert_eq!(ms, expected_ms, "{:?}", out.report);
        assert!(out.times_ns.windows(2).all(|w| w[0] < w[1]));
        out.report
    }

    #[test]
    fn resolution_follows_the_printed_digits_and_six_significant_ones() {
        let r = |t: &str| PrintedTime::parse(t).unwrap().resolution_s;
        assert!((r("839.275") - 1e-3).abs() < 1e-12);
        assert!(
            (r("1061.5") - 1e-2).abs() < 1e-12,
            "%g dropped a trailing zero"
        );
        assert!((r("1.13486e+09") - 1e4).abs() < 1e-6);
        assert!((r("1071078718.462309") - 1e-6).abs() < 1e-12);
        assert!(PrintedTime::parse("pippo").is_none());
    }

    #[test]
    fn good_stamps_are_kept_as_printed() {
        let report = check(&["O0.1", "S0.2", "O0.3", "S0.4"], &[100, 200, 300, 400]);
        assert!(report.is_clean());
    }

    #[test]
    fn a_scan_stamp_going_backwards_costs_one_stamp() {
        // 2.0 then 1.5: either could be wrong; the same one is dropped every time.
        let report = check(
            &["S1.0", "S2.0", "S1.5", "S4.0", "S5.0"],
            &[1000, 1250, 1500, 4000, 5000],
        );
        assert_eq!(report.scans.out_of_order, 1);
        assert_eq!(
            report.scans.first_problem,
            Some((2, StampProblem::OutOfOrder))
        );
    }

    #[test]
    fn one_wild_stamp_in_the_future_costs_only_itself() {
        let report = check(
            &["S1.0", "S900.0", "S3.0", "S4.0"],
            &[1000, 2000, 3000, 4000],
        );
        assert_eq!(report.scans.out_of_order, 1);
    }

    #[test]
    fn zero_stamps_of_odometry_fall_between_the_scans() {
        let report = check(
            &["S1.0", "O0", "S2.0", "O0", "O0", "S2.9"],
            &[1000, 1500, 2000, 2300, 2600, 2900],
        );
        assert_eq!(report.odometry.zero, 3);
        assert_eq!(report.scans.kept, 3);
    }

    #[test]
    fn odometry_outside_its_scans_is_out_of_order() {
        let report = check(&["S1.0", "O7.0", "S2.0"], &[1000, 1500, 2000]);
        assert_eq!(report.odometry.out_of_order, 1);
    }

    #[test]
    fn coarse_scan_stamps_are_retimed_from_the_nominal_period() {
        let report = check(
            &[
                "S1.13486e+09",
                "O1.13486e+09",
                "S1.13486e+09",
                "S1.13486e+09",
            ],
            &[200, 300, 400, 600],
        );
        assert_eq!(report.scans.coarse, 3);
        assert_eq!(report.odometry.coarse, 1);
        assert_eq!(report.scan_period_source, PeriodSource::Nominal);
        assert!(report.warnings()[0].contains("all re-timed from the scan period"));
    }

    #[test]
    fn the_scan_period_is_measured_when_enough_stamps_agree() {
        let report = check(
            &["S-1", "S10.0", "S10.5", "S11.0", "S11.5", "S0"],
            &[9500, 10000, 10500, 11000, 11500, 12000],
        );
        assert_eq!(
            report.scan_period_source,
            PeriodSource::Measured { intervals: 3 }
        );
        assert_eq!((report.scans.negative, report.scans.zero), (1, 1));
    }

    #[test]
    fn equal_stamps_are_separated_by_a_nanosecond() {
        let out = retime(
            &inputs(&["O0.5", "S0.5", "S0.5"]),
            &TimingOptions::default(),
        )
        .unwrap();
        assert_eq!(out.times_ns, [500_000_000, 500_000_001, 500_000_002]);
        assert_eq!(out.report.ties_separated, 2);
    }

    #[test]
    fn time_never_goes_below_zero_before_the_first_anchor() {
        check(&["O0", "O0", "O0", "S0.0001", "S0.2"], &[0, 0, 0, 0, 200]);
    }

    #[test]
    fn strict_policy_refuses_broken_scan_stamps_but_not_odometry() {
        let options = TimingOptions {
            policy: TimePolicy::RejectBrokenScans,
            ..TimingOptions::default()
        };
        assert!(retime(&inputs(&["S1.0", "O0", "S2.0"]), &options).is_ok());
        let err = retime(&inputs(&["S1.0", "S0", "S2.0"]), &options).unwrap_err();
        assert_eq!(
            err.to_string(),
            "1 of 3 laser scan timestamps are unusable (1 zero; the first, zero, at line 2): import with re-timing to give them times from the scan rate"
        );
    }

    #[test]
    fn missing_and_non_finite_stamps_are_reported() {
        let report = check(&["S-", "Snan", "S1e300", "S1.0"], &[400, 600, 800, 1000]);
        assert_eq!(
            (
                report.scans.missing,
                report.scans.not_finite,
                report.scans.out_of_range
            ),
            (1, 1, 1)
        );
    }

    #[test]
    fn longest_non_decreasing_keeps_ties() {
        assert_eq!(
            longest_non_decreasing(&[1, 5, 2, 2, 3]),
            [true, false, true, true, true]
        );
        assert!(longest_non_decreasing(&[]).is_empty());
    }
}
