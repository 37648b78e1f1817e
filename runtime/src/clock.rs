//! The live clock: the only place outside tests where the runtime reads the time.
//!
//! Time is `i64` nanoseconds since the Unix epoch, so that publish times in the log are
//! wall-clock times; it is read from the monotonic clock, anchored to the wall clock once,
//! so that it never jumps backwards when the system time is set.

use std::time::{Duration, Instant, SystemTime, UNIX_EPOCH};

/// The wall clock now, in nanoseconds since the Unix epoch (0 before it): for times that
/// other processes compare (a [`LiveClock`]'s anchor, when an IPC port was made).
#[must_use]
pub(crate) fn wall_ns() -> i64 {
    SystemTime::now()
        .duration_since(UNIX_EPOCH)
        .map_or(0, |d| i64::try_from(d.as_nanos()).unwrap_or(i64::MAX))
}

/// A monotonic clock that reads as nanoseconds since the Unix epoch.
#[derive(Debug, Clone, Copy)]
pub struct LiveClock {
    origin: Instant,
    origin_ns: i64,
}

impl LiveClock {
    /// A clock anchored to the wall clock now.
    #[must_use]
    pub fn new() -> Self {
        Self {
            origin: Instant::now(),
            origin_ns: wall_ns(),
        }
    }

    /// Now, in nanoseconds since the Unix epoch.
    #[must_use]
    pub fn now_ns(&self) -> i64 {
        self.to_ns(Instant::now())
    }

    /// An instant of this process as nanoseconds since the Unix epoch.
    #[must_use]
    pub fn to_ns(&self, instant: Instant) -> i64 {
        let elapsed = instant.saturating_duration_since(self.origin);
        self.origin_ns
            .saturating_add(i64::try_from(elapsed.as_nanos()).unwrap_or(i64::MAX))
    }

    /// The instant at which this clock reads `ns` (now or later; earlier times give the
    /// origin).
    #[must_use]
    pub fn to_instant(&self, ns: i64) -> Instant {
        let after = u64::try_from(ns.saturating_sub(self.origin_ns)).unwrap_or(0);
        self.origin + Duration::from_nanos(after)
    }
}

impl Default for LiveClock {
    fn default() -> Self {
        Self::new()
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn instants_and_nanoseconds_convert_both_ways() {
        let clock = LiveClock::new();
        let later = clock.origin + Duration::from_millis(1500);
        let ns = clock.to_ns(later);
        assert_eq!(ns - clock.origin_ns, 1_500_000_000);
        assert_eq!(clock.to_instant(ns), later);
        assert_eq!(clock.to_instant(clock.origin_ns - 5), clock.origin);
    }
}
