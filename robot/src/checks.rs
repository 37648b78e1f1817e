//! The checks of a provider's published data that an interface's providers are held to
//! (rate, freshness, values, frozen stream), with defaults that suit each interface and the
//! overrides a robot file declares under `[broker.interfaces.NAME] checks = { ... }`.
//!
//! The checks themselves run in the broker's health module; this is only what they are
//! told. Why these defaults:
//! - rate: half the declared `data_rate_hz` over a second (at least four periods) catches a
//!   sensor at a third of its rate (the replay's `:slow` fault) and no scheduling hiccup on a
//!   loaded machine; it applies only to providers that declare a rate, and by default only
//!   to the streams a device produces on its own clock (scans, odometry, frames, power),
//!   not to data computed from other data, which stops when its input does.
//! - freshness: a sample published more than 500 ms before the broker sees it is stale (a
//!   clock that is a few milliseconds off between two processes is not).
//! - values: every interface's data must decode as its message; the numbers must be finite.
//! - frozen: only where the data is a noisy measurement (a range finder's scan): identical
//!   readings, noise and all, mean a stuck device. Never for odometry (a robot at rest
//!   publishes the same pose), lists (an empty blob list repeats), or derived data.

use serde::Deserialize;

/// What a failed check does to its provider.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Default, Deserialize)]
#[serde(rename_all = "kebab-case")]
pub enum OnCheckFailure {
    /// The provider has failed: it is stopped and its clients move (as for a stall).
    #[default]
    Failed,
    /// The provider is degraded: recorded and shown, its clients stay.
    Degraded,
}

/// The data checks of one interface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub struct DataChecks {
    /// The least fraction of a provider's `data_rate_hz` it must keep over `window_ms`; 0
    /// turns the rate check off.
    pub min_rate_fraction: f64,
    /// The window of the rate check, in milliseconds; the rate is judged only once a
    /// provider has been watched this long.
    pub window_ms: u64,
    /// How far a sample's publish time may be behind the broker's clock when it sees it, in
    /// milliseconds; `None` turns the freshness check off.
    pub freshness_ms: Option<u64>,
    /// Whether each sample must decode as the interface's message with finite numbers,
    /// consistent array sizes and the interface's own ranges.
    pub values: bool,
    /// How many identical payloads (header aside) in a row make a frozen stream; `None`
    /// turns the frozen check off.
    pub frozen_count: Option<u32>,
    /// What a failed check does.
    pub on_failure: OnCheckFailure,
}

/// The least number of identical payloads a frozen check may count: one repeat is too
/// easily a coincidence of a quantised sensor.
pub const MIN_FROZEN_COUNT: u32 = 2;

impl DataChecks {
    /// The checks that suit `interface` when the robot file says nothing.
    #[must_use]
    pub fn default_for(interface: &str) -> Self {
        let frozen_count = match interface {
            "RangeFinder" => Some(5),
            _ => None,
        };
        // Streams a device produces on its own clock. Data computed from other data (a blob
        // list, a Distance from a scan, a Mover's status) stops when its input does: that is
        // the input's provider's failure, not the computing service's.
        let sensor_stream = matches!(
            interface,
            "RangeFinder"
                | "Egomotion"
                | "Synchrodrive"
                | "GroundTruth"
                | "WorldState"
                | "ImageSource"
                | "Power"
        );
        Self {
            min_rate_fraction: if sensor_stream { 0.5 } else { 0.0 },
            window_ms: 1_000,
            freshness_ms: Some(500),
            values: true,
            frozen_count,
            on_failure: OnCheckFailure::Failed,
        }
    }

    /// Every check off: what a robot that does not want data checks gets.
    #[must_use]
    pub fn none() -> Self {
        Self {
            min_rate_fraction: 0.0,
            window_ms: 1_000,
            freshness_ms: None,
            values: false,
            frozen_count: None,
            on_failure: OnCheckFailure::Failed,
        }
    }

    /// Whether any check is on.
    #[must_use]
    pub fn any(&self) -> bool {
        self.min_rate_fraction > 0.0
            || self.freshness_ms.is_some()
            || self.values
            || self.frozen_count.is_some()
    }
}
