//! The pace of a playback: which wall-clock instant each recorded log time is due at, for a
//! rate, with pause, step and restart. Pure: instants come in as arguments, so it is tested
//! without a clock.

use std::time::{Duration, Instant};

/// Maps log time to wall time (see the module documentation).
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct Pacer {
    rate: f64,
    wall_anchor: Instant,
    log_anchor_ns: i64,
    paused_at_ns: Option<i64>,
}

impl Pacer {
    /// Log time `log_ns` is now (`now`); `rate` recorded seconds per wall second (positive
    /// and finite: the caller checks it).
    #[must_use]
    pub fn new(rate: f64, now: Instant, log_ns: i64, paused: bool) -> Self {
        Self {
            rate,
            wall_anchor: now,
            log_anchor_ns: log_ns,
            paused_at_ns: paused.then_some(log_ns),
        }
    }

    /// The rate.
    #[must_use]
    pub fn rate(&self) -> f64 {
        self.rate
    }

    /// Whether it is paused.
    #[must_use]
    pub fn is_paused(&self) -> bool {
        self.paused_at_ns.is_some()
    }

    /// The log time at wall instant `now` (the paused time while paused).
    #[must_use]
    pub fn log_time_at(&self, now: Instant) -> i64 {
        if let Some(at) = self.paused_at_ns {
            return at;
        }
        let elapsed = now
            .saturating_duration_since(self.wall_anchor)
            .as_secs_f64();
        // Seconds of a playback times a sane rate fit an i64 of nanoseconds.
        let played_ns = (elapsed * self.rate * 1e9) as i64;
        self.log_anchor_ns.saturating_add(played_ns)
    }

    /// The wall instant at which log time `log_ns` is due; `None` while paused.
    #[must_use]
    pub fn due(&self, log_ns: i64) -> Option<Instant> {
        if self.is_paused() {
            return None;
        }
        // nanoseconds of a recording: exact to 2^53
        let ahead_s = log_ns.saturating_sub(self.log_anchor_ns).max(0) as f64 / 1e9 / self.rate;
        Some(self.wall_anchor + Duration::from_secs_f64(ahead_s.min(1e9)))
    }

    /// Pauses at the log time of `now`.
    pub fn pause(&mut self, now: Instant) {
        if !self.is_paused() {
            self.paused_at_ns = Some(self.log_time_at(now));
        }
    }

    /// Resumes from the paused log time, now.
    pub fn resume(&mut self, now: Instant) {
        if let Some(at) = self.paused_at_ns.take() {
            self.wall_anchor = now;
            self.log_anchor_ns = at;
        }
    }

    /// A message at `log_ns` was stepped to while paused: the paused time moves to it.
    pub fn stepped(&mut self, log_ns: i64) {
        if let Some(at) = &mut self.paused_at_ns {
            *at = (*at).max(log_ns);
        }
    }

    /// Starts again at `log_ns`, now (a loop, a seek); the pause state is kept.
    pub fn restart(&mut self, now: Instant, log_ns: i64) {
        self.wall_anchor = now;
        self.log_anchor_ns = log_ns;
        if self.paused_at_ns.is_some() {
            self.paused_at_ns = Some(log_ns);
        }
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: i64 = 1_000_000_000;

    #[test]
    fn log_time_is_due_at_its_offset_divided_by_the_rate() {
        let t0 = Instant::now();
        let pacer = Pacer::new(2.0, t0, 10 * S, false);
        assert_eq!(pacer.due(10 * S), Some(t0));
        assert_eq!(pacer.due(14 * S), Some(t0 + Duration::from_secs(2)));
        // What is already late is due at once.
        assert_eq!(pacer.due(5 * S), Some(t0));
        assert_eq!(pacer.log_time_at(t0 + Duration::from_secs(3)), 16 * S);
    }

    #[test]
    fn a_pause_holds_the_time_and_a_resume_goes_on_from_it() {
        let t0 = Instant::now();
        let mut pacer = Pacer::new(1.0, t0, 0, false);
        pacer.pause(t0 + Duration::from_secs(3));
        assert!(pacer.is_paused());
        assert_eq!(pacer.due(4 * S), None);
        assert_eq!(pacer.log_time_at(t0 + Duration::from_secs(100)), 3 * S);
        pacer.stepped(5 * S);
        assert_eq!(pacer.log_time_at(t0 + Duration::from_secs(100)), 5 * S);
        let t1 = t0 + Duration::from_secs(100);
        pacer.resume(t1);
        assert_eq!(pacer.due(6 * S), Some(t1 + Duration::from_secs(1)));
    }

    #[test]
    fn a_restart_anchors_the_new_start_now() {
        let t0 = Instant::now();
        let mut pacer = Pacer::new(1.0, t0, 0, false);
        let t1 = t0 + Duration::from_secs(50);
        pacer.restart(t1, 0);
        assert_eq!(pacer.due(2 * S), Some(t1 + Duration::from_secs(2)));
    }
}
