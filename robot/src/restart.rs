//! How a supervised process is restarted: the robot file's `restart` table. The logic that
//! applies it (intensity over a window, backoff) is the runtime's `supervise::policy`.

use serde::Deserialize;

/// How a supervised process is restarted after it fails: at most `max_restarts` restarts
/// within any `window_ms`, each after an exponential backoff (`backoff_initial_ms`,
/// doubling, capped at `backoff_max_ms`), like systemd's `StartLimitBurst`/`RestartSec` or
/// OTP's intensity and period.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Deserialize)]
#[serde(deny_unknown_fields)]
pub struct RestartPolicy {
    /// Restarts allowed within the window; one more failure gives up.
    pub max_restarts: u32,
    /// The sliding window over which failures are counted, in milliseconds.
    pub window_ms: u64,
    /// The delay before the first restart, in milliseconds.
    #[serde(default = "default_backoff_initial_ms")]
    pub backoff_initial_ms: u64,
    /// The longest delay between restarts, in milliseconds.
    #[serde(default = "default_backoff_max_ms")]
    pub backoff_max_ms: u64,
}

fn default_backoff_initial_ms() -> u64 {
    50
}

fn default_backoff_max_ms() -> u64 {
    2_000
}

impl Default for RestartPolicy {
    fn default() -> Self {
        Self {
            max_restarts: 3,
            window_ms: 10_000,
            backoff_initial_ms: default_backoff_initial_ms(),
            backoff_max_ms: default_backoff_max_ms(),
        }
    }
}
