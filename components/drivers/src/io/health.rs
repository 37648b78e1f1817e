//! What a driver says about its device, which the service adapter maps to the runtime's health
//! (anything but [`DriverHealth::Ok`] is out of service, with [`DriverHealth::reason`]).

use std::collections::VecDeque;
use std::path::PathBuf;
use std::time::Duration;

/// A driver's view of its device.
#[derive(Debug, Clone, PartialEq)]
pub enum DriverHealth {
    /// Valid data within the deadline and few checksum errors.
    Ok,
    /// The port is closed (unplugged, or could not be set up again); the driver retries.
    Disconnected {
        /// The port.
        path: PathBuf,
        /// What happened last.
        reason: String,
    },
    /// The port is open but the device could not be set up (no answer at any rate, a
    /// refused command); the driver retries.
    NotSetUp {
        /// The set-up's error, which names the port and what to check.
        reason: String,
    },
    /// No valid data for longer than the deadline.
    NoData {
        /// The port.
        path: PathBuf,
        /// Time since the last valid data (or since the device was set up).
        silent_for: Duration,
        /// The deadline.
        deadline: Duration,
    },
    /// Too many of the recent frames had a bad checksum.
    ChecksumErrors {
        /// The port.
        path: PathBuf,
        /// Fraction of the recent frames with a bad CRC or checksum.
        error_rate: f64,
        /// The threshold it passed.
        threshold: f64,
    },
}

impl DriverHealth {
    /// Whether all is well.
    pub fn is_ok(&self) -> bool {
        matches!(self, Self::Ok)
    }

    /// Why the device is out of service, for the health report; `None` when it is fine.
    pub fn reason(&self) -> Option<String> {
        match self {
            Self::Ok => None,
            Self::Disconnected { path, reason } => {
                Some(format!("{} disconnected: {reason}", path.display()))
            }
            Self::NotSetUp { reason } => Some(reason.clone()),
            Self::NoData {
                path,
                silent_for,
                deadline,
            } => Some(format!(
                "no valid data on {} for {:.3} s (deadline {:.3} s)",
                path.display(),
                silent_for.as_secs_f64(),
                deadline.as_secs_f64()
            )),
            Self::ChecksumErrors {
                path,
                error_rate,
                threshold,
            } => Some(format!(
                "{:.0}% of recent frames on {} have a bad checksum (threshold {:.0}%)",
                error_rate * 100.0,
                path.display(),
                threshold * 100.0
            )),
        }
    }
}

/// The outcomes (good frame or checksum error) of the last `capacity` frames.
#[derive(Debug, Clone)]
pub(crate) struct ErrorWindow {
    capacity: usize,
    outcomes: VecDeque<bool>,
    errors: usize,
}

impl ErrorWindow {
    pub(crate) fn new(capacity: usize) -> Self {
        Self {
            capacity: capacity.max(1),
            outcomes: VecDeque::new(),
            errors: 0,
        }
    }

    /// Records `good` good frames and `bad` bad ones.
    pub(crate) fn record(&mut self, good: u64, bad: u64) {
        for _ in 0..bad.min(self.capacity as u64) {
            self.push(true);
        }
        for _ in 0..good.min(self.capacity as u64) {
            self.push(false);
        }
    }

    fn push(&mut self, error: bool) {
        self.outcomes.push_back(error);
        self.errors += usize::from(error);
        while self.outcomes.len() > self.capacity {
            if self.outcomes.pop_front() == Some(true) {
                self.errors -= 1;
            }
        }
    }

    pub(crate) fn clear(&mut self) {
        self.outcomes.clear();
        self.errors = 0;
    }

    /// The error fraction once the window holds at least a quarter of its capacity (fewer
    /// frames say too little), else 0.
    pub(crate) fn error_rate(&self) -> f64 {
        if self.outcomes.len() * 4 < self.capacity {
            return 0.0;
        }
        self.errors as f64 / self.outcomes.len() as f64
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn the_window_forgets_old_errors() {
        let mut window = ErrorWindow::new(8);
        window.record(0, 4);
        assert_eq!(window.error_rate(), 1.0);
        window.record(8, 0);
        assert_eq!(window.error_rate(), 0.0);
        window.record(6, 2);
        assert_eq!(window.error_rate(), 0.25);
    }

    #[test]
    fn a_nearly_empty_window_reports_no_rate() {
        let mut window = ErrorWindow::new(20);
        window.record(0, 4);
        assert_eq!(window.error_rate(), 0.0);
        window.record(0, 1);
        assert_eq!(window.error_rate(), 1.0);
    }

    #[test]
    fn reasons_name_the_port() {
        let health = DriverHealth::NoData {
            path: PathBuf::from("/dev/ttyS1"),
            silent_for: Duration::from_millis(1500),
            deadline: Duration::from_secs(1),
        };
        let reason = health.reason().unwrap();
        assert!(
            reason.contains("/dev/ttyS1") && reason.contains("1.500"),
            "{reason}"
        );
        assert_eq!(DriverHealth::Ok.reason(), None);
    }
}
