//! The clock a live service reads ([`Context::now`](lewis_service::Context::now) and its
//! ticks): the machine's, or the time of a recording played into IPC (`lewis play`, on
//! `/lewis/clock`), like ROS 2's `use_sim_time`.
//!
//! Following a played clock, a service's time is the last [`Clock`] sample advanced by its
//! rate since it was received (the player publishes every 10 ms of wall time, so the
//! extrapolation is short). Before the first sample the time is 0 and does not advance: the
//! service's ticks wait for the player, as they would wait for a recording to start. Paused,
//! the time stands still, and so do the ticks. Small steps back (a sample older than the
//! extrapolation had reached) are not shown: the time never goes backwards by less than
//! [`JUMP_BACK`]; a larger step back is the player starting again (`--loop`, a new run) and
//! is followed.

use std::fmt;
use std::str::FromStr;
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::Clock;

use crate::clock::LiveClock;
use crate::ipc::{Ipc, IpcError, Subscriber, Waitable};
use crate::names;

/// A step back of the played time shorter than this is extrapolation catching up, not the
/// player starting again.
pub const JUMP_BACK: Duration = Duration::from_millis(500);

/// Which time a live service reads.
#[derive(Debug, Clone, Copy, Default, PartialEq, Eq)]
pub enum ClockSource {
    /// The machine's monotonic clock, as nanoseconds since the Unix epoch.
    #[default]
    Wall,
    /// The time of the recording played on `/lewis/clock`.
    Played,
}

/// The environment variable that gives `lewis service` its [`ClockSource`] (`lewis up
/// --clock played` sets it for every service it starts).
pub const CLOCK_ENV: &str = "LEWIS_CLOCK";

impl ClockSource {
    /// The value of [`CLOCK_ENV`] that means this source.
    #[must_use]
    pub fn as_str(self) -> &'static str {
        match self {
            Self::Wall => "wall",
            Self::Played => "played",
        }
    }
}

impl fmt::Display for ClockSource {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.write_str(self.as_str())
    }
}

/// A clock source name that is neither `wall` nor `played`.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error(
    "unknown clock `{0}`: the clocks are `wall` (the machine's) and `played` (lewis play's /lewis/clock)"
)]
pub struct UnknownClock(pub String);

impl FromStr for ClockSource {
    type Err = UnknownClock;

    fn from_str(s: &str) -> Result<Self, Self::Err> {
        match s {
            "wall" => Ok(Self::Wall),
            "played" => Ok(Self::Played),
            other => Err(UnknownClock(other.to_owned())),
        }
    }
}

/// The clock of one live service.
pub(super) enum ServiceClock {
    Wall(LiveClock),
    Played(Box<PlayedClock>),
}

impl ServiceClock {
    /// The clock `source` names; a played clock subscribes to `/lewis/clock`.
    pub(super) fn open(source: ClockSource, ipc: &Ipc) -> Result<Self, IpcError> {
        Ok(match source {
            ClockSource::Wall => Self::Wall(LiveClock::new()),
            ClockSource::Played => Self::Played(Box::new(PlayedClock {
                subscriber: ipc.subscriber(names::CLOCK_CHANNEL, &names::clock_config())?,
                time: PlayedTime::default(),
            })),
        })
    }

    /// Now, in nanoseconds; a played clock first takes the newest clock sample.
    pub(super) fn now_ns(&mut self) -> i64 {
        match self {
            Self::Wall(clock) => clock.now_ns(),
            Self::Played(played) => {
                played.take_samples();
                played.time.now_ns(Instant::now())
            }
        }
    }

    /// Whether the clock has a time: a played clock not before its first sample.
    pub(super) fn started(&self) -> bool {
        match self {
            Self::Wall(_) => true,
            Self::Played(played) => played.time.anchor.is_some(),
        }
    }

    /// When this clock will read `ns`, if it is advancing.
    pub(super) fn instant_at(&self, ns: i64) -> Option<Instant> {
        match self {
            Self::Wall(clock) => Some(clock.to_instant(ns)),
            Self::Played(played) => played.time.instant_at(ns, Instant::now()),
        }
    }

    /// What wakes the service when the clock changes its pace (a played clock's samples).
    pub(super) fn waitable(&self) -> Option<&dyn Waitable> {
        match self {
            Self::Wall(_) => None,
            Self::Played(played) => Some(&played.subscriber),
        }
    }
}

pub(super) struct PlayedClock {
    subscriber: Subscriber,
    time: PlayedTime,
}

impl PlayedClock {
    fn take_samples(&mut self) {
        loop {
            match self.subscriber.receive() {
                Ok(Some(sample)) => match cdr::from_bytes::<Clock>(sample.bytes()) {
                    Ok(clock) => self.time.set(&clock, Instant::now()),
                    Err(e) => tracing::warn!("a clock sample that does not decode: {e}"),
                },
                Ok(None) => return,
                Err(e) => {
                    tracing::warn!("cannot read /lewis/clock: {e}");
                    return;
                }
            }
        }
    }
}

/// The played time: pure, the wall instants are arguments.
#[derive(Debug, Clone, Copy, Default, PartialEq)]
struct PlayedTime {
    /// The last sample and when it was received.
    anchor: Option<Anchor>,
    /// The latest time read, under which small steps back are not shown.
    shown_ns: i64,
}

#[derive(Debug, Clone, Copy, PartialEq)]
struct Anchor {
    time_ns: i64,
    /// Played nanoseconds per wall nanosecond; 0 when paused.
    rate: f64,
    at: Instant,
}

impl PlayedTime {
    fn set(&mut self, clock: &Clock, at: Instant) {
        let rate = if clock.paused || !clock.rate.is_finite() {
            0.0
        } else {
            clock.rate.max(0.0)
        };
        if clock.time_ns + nanos(JUMP_BACK) < self.shown_ns {
            // The player started again.
            self.shown_ns = clock.time_ns;
        }
        self.anchor = Some(Anchor {
            time_ns: clock.time_ns,
            rate,
            at,
        });
    }

    fn now_ns(&mut self, now: Instant) -> i64 {
        let Some(anchor) = self.anchor else {
            return 0;
        };
        let elapsed = now.saturating_duration_since(anchor.at).as_nanos() as f64;
        // Saturating float to integer: a rate of 1e30 cannot overflow.
        let played = anchor
            .time_ns
            .saturating_add((elapsed * anchor.rate) as i64);
        self.shown_ns = self.shown_ns.max(played);
        self.shown_ns
    }

    fn instant_at(&self, ns: i64, now: Instant) -> Option<Instant> {
        let anchor = self.anchor?;
        if ns <= self.shown_ns {
            return Some(now);
        }
        if anchor.rate <= 0.0 {
            return None;
        }
        let wall = (ns.saturating_sub(anchor.time_ns)) as f64 / anchor.rate;
        Some(anchor.at + Duration::from_secs_f64(wall.clamp(0.0, 1e9) / 1e9))
    }
}

fn nanos(duration: Duration) -> i64 {
    i64::try_from(duration.as_nanos()).unwrap_or(i64::MAX)
}

#[cfg(test)]
mod tests {
    use super::*;

    fn clock(time_ns: i64, rate: f64, paused: bool) -> Clock {
        Clock {
            time_ns,
            rate,
            paused,
            ..Clock::default()
        }
    }

    const MS: Duration = Duration::from_millis(1);

    #[test]
    fn the_played_time_advances_at_the_rate_from_the_last_sample_and_stands_when_paused() {
        let start = Instant::now();
        let mut time = PlayedTime::default();
        assert_eq!(time.now_ns(start), 0);
        assert_eq!(
            time.instant_at(5, start),
            None,
            "no clock yet: no tick is due"
        );
        time.set(&clock(1_000_000_000, 2.0, false), start);
        assert_eq!(time.now_ns(start + 10 * MS), 1_020_000_000);
        assert_eq!(
            time.instant_at(1_100_000_000, start + 10 * MS),
            Some(start + 50 * MS)
        );
        time.set(&clock(1_030_000_000, 2.0, true), start + 15 * MS);
        assert_eq!(time.now_ns(start + 500 * MS), 1_030_000_000);
        assert_eq!(time.instant_at(1_100_000_000, start + 500 * MS), None);
        assert_eq!(
            time.instant_at(1_000_000_000, start + 500 * MS),
            Some(start + 500 * MS),
            "a time already passed is due now"
        );
    }

    #[test]
    fn small_steps_back_are_hidden_and_a_restart_is_followed() {
        let start = Instant::now();
        let mut time = PlayedTime::default();
        time.set(&clock(1_000_000_000, 1.0, false), start);
        assert_eq!(time.now_ns(start + 20 * MS), 1_020_000_000);
        // A sample a little behind the extrapolation: the time holds, then goes on.
        time.set(&clock(1_010_000_000, 1.0, false), start + 20 * MS);
        assert_eq!(time.now_ns(start + 25 * MS), 1_020_000_000);
        assert_eq!(time.now_ns(start + 40 * MS), 1_030_000_000);
        // The player loops back to the start of the recording.
        time.set(&clock(0, 1.0, false), start + 50 * MS);
        assert_eq!(time.now_ns(start + 60 * MS), 10_000_000);
    }

    #[test]
    fn clock_sources_are_named_and_unknown_names_say_the_known_ones() {
        for source in [ClockSource::Wall, ClockSource::Played] {
            assert_eq!(source.as_str().parse(), Ok(source));
        }
        let error = "sim".parse::<ClockSource>().unwrap_err().to_string();
        assert!(
            error.contains("`wall`") && error.contains("`played`"),
            "{error}"
        );
    }
}
