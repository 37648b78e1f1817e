//! Restart intensity and backoff: how often a failing process may be restarted, and when.
//!
//! Pure logic on explicit timestamps, so the broker's decision core (which must replay
//! identically) and the live supervisor share it.

use std::collections::VecDeque;

use lewis_robot::RestartPolicy;

/// What to do after a failure.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum RestartDecision {
    /// Restart at this time (nanoseconds, on the caller's clock).
    RestartAt {
        /// When to start the process again.
        at_ns: i64,
        /// Which restart this is within the window, counting from 1.
        attempt: u32,
    },
    /// The policy's intensity is exceeded: do not restart.
    GiveUp {
        /// Failures seen within the window, this one included.
        failures: u32,
    },
}

/// Tracks the failures of one process against a [`RestartPolicy`].
#[derive(Debug, Clone)]
pub struct RestartTracker {
    policy: RestartPolicy,
    /// Failure times within the window, oldest first; bounded by `max_restarts + 1`.
    failures_ns: VecDeque<i64>,
}

impl RestartTracker {
    /// A tracker with no failures yet.
    #[must_use]
    pub fn new(policy: RestartPolicy) -> Self {
        Self {
            policy,
            failures_ns: VecDeque::new(),
        }
    }

    /// The policy this tracker applies.
    #[must_use]
    pub fn policy(&self) -> RestartPolicy {
        self.policy
    }

    /// Records a failure at `now_ns` and decides whether and when to restart.
    pub fn on_failure(&mut self, now_ns: i64) -> RestartDecision {
        let window_ns =
            i64::try_from(self.policy.window_ms.saturating_mul(1_000_000)).unwrap_or(i64::MAX);
        while let Some(&oldest) = self.failures_ns.front() {
            if now_ns.saturating_sub(oldest) >= window_ns {
                self.failures_ns.pop_front();
            } else {
                break;
            }
        }
        self.failures_ns.push_back(now_ns);
        let failures = u32::try_from(self.failures_ns.len()).unwrap_or(u32::MAX);
        if failures > self.policy.max_restarts {
            // Keep the bound: only the last `max_restarts + 1` failures can matter.
            while self.failures_ns.len() > self.policy.max_restarts as usize + 1 {
                self.failures_ns.pop_front();
            }
            return RestartDecision::GiveUp { failures };
        }
        let shift = (failures - 1).min(30);
        let delay_ms = self
            .policy
            .backoff_initial_ms
            .saturating_mul(1 << shift)
            .min(self.policy.backoff_max_ms);
        let delay_ns = i64::try_from(delay_ms.saturating_mul(1_000_000)).unwrap_or(i64::MAX);
        RestartDecision::RestartAt {
            at_ns: now_ns.saturating_add(delay_ns),
            attempt: failures,
        }
    }

    /// Forgets past failures (after an operator intervention, or a fail back).
    pub fn reset(&mut self) {
        self.failures_ns.clear();
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const MS: i64 = 1_000_000;

    fn policy(max_restarts: u32, window_ms: u64) -> RestartPolicy {
        RestartPolicy {
            max_restarts,
            window_ms,
            backoff_initial_ms: 10,
            backoff_max_ms: 35,
        }
    }

    fn check(policy: RestartPolicy, failures_at_ms: &[i64], expected: &[RestartDecision]) {
        let mut tracker = RestartTracker::new(policy);
        let got: Vec<_> = failures_at_ms
            .iter()
            .map(|&t| tracker.on_failure(t * MS))
            .collect();
        assert_eq!(got, expected);
    }

    #[test]
    fn backoff_doubles_up_to_the_cap_then_gives_up_beyond_the_limit() {
        use RestartDecision::{GiveUp, RestartAt};
        check(
            policy(3, 1_000),
            &[0, 100, 200, 300],
            &[
                RestartAt {
                    at_ns: 10 * MS,
                    attempt: 1,
                },
                RestartAt {
                    at_ns: 120 * MS,
                    attempt: 2,
                },
                RestartAt {
                    at_ns: 235 * MS,
                    attempt: 3,
                },
                GiveUp { failures: 4 },
            ],
        );
    }

    #[test]
    fn failures_older_than_the_window_are_forgotten() {
        use RestartDecision::RestartAt;
        check(
            policy(1, 1_000),
            &[0, 1_000, 2_500],
            &[
                RestartAt {
                    at_ns: 10 * MS,
                    attempt: 1,
                },
                RestartAt {
                    at_ns: 1_010 * MS,
                    attempt: 1,
                },
                RestartAt {
                    at_ns: 2_510 * MS,
                    attempt: 1,
                },
            ],
        );
    }

    #[test]
    fn zero_restarts_gives_up_at_the_first_failure() {
        check(
            policy(0, 1_000),
            &[5],
            &[RestartDecision::GiveUp { failures: 1 }],
        );
    }
}
