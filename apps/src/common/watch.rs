//! The fail-safe's watch: when each required input last gave a sample.
//!
//! A program that loses an input it cannot work without (the scan, the odometry) for longer
//! than its staleness limit stops the robot and ends with [`super::exit::INPUT_LOST`]. Until
//! the first sample a longer grace applies: the broker may be starting the provider.

use std::collections::BTreeMap;

/// How long a required input may be silent once it has spoken, in ns (`--stale`): longer
/// than the broker takes to fail a crashing provider over to another one (its restarts
/// with their backoff, then the other's start; 2.3 s when the demo kills the laser), so
/// that a failover is not an input lost. Lived again (`lewis replay --all`), a 2 s limit
/// failed the mission whenever a program held a sample of the laser's last second.
pub const DEFAULT_STALE_NS: i64 = 5_000_000_000;

/// How long a required input may take to give its first sample, in ns: the broker starts an
/// on-demand provider when the program asks for it, which takes a process start.
pub const STARTUP_GRACE_NS: i64 = 6_000_000_000;

/// The last sample time of each watched interface.
#[derive(Debug, Clone)]
pub struct Watch {
    stale_ns: i64,
    started_ns: Option<i64>,
    last_ns: BTreeMap<&'static str, Option<i64>>,
}

impl Watch {
    /// Watches `interfaces`, each allowed `stale_ns` of silence.
    #[must_use]
    pub fn new(interfaces: &[&'static str], stale_ns: i64) -> Self {
        Self {
            stale_ns,
            started_ns: None,
            last_ns: interfaces.iter().map(|i| (*i, None)).collect(),
        }
    }

    /// The program started at `now_ns`.
    pub fn start(&mut self, now_ns: i64) {
        self.started_ns.get_or_insert(now_ns);
    }

    /// A sample of `interface` came at `now_ns`.
    pub fn saw(&mut self, interface: &str, now_ns: i64) {
        if let Some(last) = self.last_ns.get_mut(interface) {
            *last = Some(now_ns);
        }
    }

    /// The first watched interface that is silent for too long at `now_ns`, if any.
    #[must_use]
    pub fn lost(&self, now_ns: i64) -> Option<&'static str> {
        let started = self.started_ns?;
        self.last_ns.iter().find_map(|(name, last)| {
            let silent = match last {
                Some(at) => now_ns - at > self.stale_ns,
                None => now_ns - started > self.stale_ns.max(STARTUP_GRACE_NS),
            };
            silent.then_some(*name)
        })
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    const S: i64 = 1_000_000_000;

    #[test]
    fn an_input_is_lost_after_its_silence_and_a_first_sample_gets_a_grace() {
        let mut watch = Watch::new(&["RangeFinder", "Egomotion"], 2 * S);
        assert_eq!(watch.lost(100 * S), None, "not started yet");
        watch.start(0);
        watch.saw("Egomotion", S);
        assert_eq!(watch.lost(5 * S / 2), None);
        assert_eq!(watch.lost(7 * S / 2), Some("Egomotion"));
        watch.saw("Egomotion", 11 * S / 2);
        assert_eq!(watch.lost(STARTUP_GRACE_NS), None, "the grace");
        assert_eq!(watch.lost(STARTUP_GRACE_NS + 1), Some("RangeFinder"));
        watch.saw("RangeFinder", 6 * S);
        watch.saw("Egomotion", 6 * S);
        assert_eq!(watch.lost(8 * S), None);
        assert_eq!(watch.lost(8 * S + 1), Some("Egomotion"));
    }
}
