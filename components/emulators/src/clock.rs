//! The monotonic clock of the emulators, as i64 nanoseconds since a chosen epoch: what the
//! pure device state machines take as `now_ns`.

use std::time::Instant;

/// Nanoseconds since the clock was made, from [`Instant`] (never goes back).
#[derive(Debug, Clone, Copy)]
pub struct MonotonicClock {
    epoch: Instant,
}

impl MonotonicClock {
    /// A clock whose zero is now.
    pub fn new() -> Self {
        Self {
            epoch: Instant::now(),
        }
    }

    /// Nanoseconds since the epoch (saturating after 292 years).
    pub fn now_ns(&self) -> i64 {
        i64::try_from(self.epoch.elapsed().as_nanos()).unwrap_or(i64::MAX)
    }
}

impl Default for MonotonicClock {
    fn default() -> Self {
        Self::new()
    }
}
