//! When the next sample of a periodic stream is due, learned from the times it arrived: the
//! heart of [`WakeMode::Predictive`](super::WakeMode::Predictive), which blocks in the kernel
//! until just before that time and spins across it, so that a periodic stream is received
//! at busy-polling latency for a small share of a core.
//!
//! The period is a smoothed mean of the intervals between arrivals. An interval far from it
//! (a missed sample, a burst) does not move it, unless such intervals keep coming: then the
//! stream's rate has changed and the newest interval becomes the period.

use std::cell::Cell;
use std::time::{Duration, Instant};

/// An interval longer than the period by more than half of it, or shorter by more than a
/// third, is an outlier (a sample missed or late, a burst): a 10% jitter is not.
const OUTLIER_NUM: u32 = 3;
const OUTLIER_DEN: u32 = 2;
/// Outliers in a row after which the rate is taken to have changed.
const OUTLIERS_TO_RELEARN: u32 = 4;
/// The weight of the newest interval in the smoothed period, as 1/N.
const SMOOTHING: u32 = 8;

/// The arrival times of one stream and the period learned from them. Interior mutability,
/// so that a wait set shared by reference can learn while it waits.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub(crate) struct ArrivalPredictor {
    last: Cell<Option<Instant>>,
    period: Cell<Option<Duration>>,
    outliers: Cell<u32>,
}

impl ArrivalPredictor {
    /// The time window in which to spin, `margin` either side of the next predicted
    /// arrival; `None` until two arrivals have given a period.
    pub(crate) fn window(&self, margin: Duration) -> Option<(Instant, Instant)> {
        let next = self.last.get()? + self.period.get()?;
        Some((next.checked_sub(margin).unwrap_or(next), next + margin))
    }

    /// A sample arrived at `at` (seen while waiting for it, so `at` is close to its arrival).
    pub(crate) fn arrived(&self, at: Instant) {
        let Some(last) = self.last.replace(Some(at)) else {
            return;
        };
        let Some(interval) = at.checked_duration_since(last).filter(|d| !d.is_zero()) else {
            return;
        };
        let Some(period) = self.period.get() else {
            self.period.set(Some(interval));
            return;
        };
        let outlier = interval * OUTLIER_DEN > period * OUTLIER_NUM
            || interval * OUTLIER_NUM < period * OUTLIER_DEN;
        if outlier {
            let count = self.outliers.get() + 1;
            if count < OUTLIERS_TO_RELEARN {
                self.outliers.set(count);
                return;
            }
            self.period.set(Some(interval));
        } else {
            self.period
                .set(Some((period * (SMOOTHING - 1) + interval) / SMOOTHING));
        }
        self.outliers.set(0);
    }

    /// The period learned so far.
    #[cfg(test)]
    pub(crate) fn period(&self) -> Option<Duration> {
        self.period.get()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    fn us(n: u64) -> Duration {
        Duration::from_micros(n)
    }

    /// Feeds arrivals at the given offsets (µs) from one origin; returns the predictor and
    /// the origin.
    fn fed(offsets_us: &[u64]) -> (ArrivalPredictor, Instant) {
        let origin = Instant::now();
        let p = ArrivalPredictor::default();
        for &offset in offsets_us {
            p.arrived(origin + us(offset));
        }
        (p, origin)
    }

    #[test]
    fn no_window_until_two_arrivals_have_given_a_period() {
        assert_eq!(fed(&[]).0.window(us(10)), None);
        assert_eq!(fed(&[100]).0.window(us(10)), None);
        let (p, origin) = fed(&[100, 600]);
        assert_eq!(
            p.window(us(50)),
            Some((origin + us(1050), origin + us(1150)))
        );
    }

    #[test]
    fn the_period_follows_a_jittery_stream_and_ignores_a_missed_sample() {
        fn check(offsets_us: &[u64], expected_period_us: u64) {
            let (p, _) = fed(offsets_us);
            assert_eq!(p.period(), Some(us(expected_period_us)), "{offsets_us:?}");
        }
        check(&[0, 500, 1000, 1500], 500);
        // One interval of 540 moves the mean by 1/8 of the difference.
        check(&[0, 500, 1040], 505);
        // A missed sample (an interval of 1000 after 500s) is an outlier.
        check(&[0, 500, 1500], 500);
        // A rate that changed for good is relearnt after a few outliers.
        check(&[0, 500, 2500, 4500, 6500, 8500], 2000);
    }
}
