//! When a driver next tries to reopen a port that went away: both drivers retry every
//! `reconnect_interval` while their read is called, and wait for the retry without a
//! descriptor to wait on.

use std::time::{Duration, Instant};

use super::cancel::Cancel;

/// The reconnection schedule of one driver.
#[derive(Debug, Clone)]
pub(crate) struct Retry {
    interval: Duration,
    next_at: Instant,
}

impl Retry {
    /// A schedule retrying every `interval`, the first retry due at once.
    pub(crate) fn new(interval: Duration) -> Self {
        Self {
            interval,
            next_at: Instant::now(),
        }
    }

    /// Makes the next retry due at once (the port just went away).
    pub(crate) fn now(&mut self) {
        self.next_at = Instant::now();
    }

    /// Whether a retry is due: if so, schedules the one after it and returns true; if not,
    /// waits for it, at most until `deadline` or until `cancel` is set (there is no
    /// descriptor to wait on while the port is away), and returns false.
    pub(crate) fn due_or_wait(&mut self, deadline: Instant, cancel: Option<&Cancel>) -> bool {
        let now = Instant::now();
        if now < self.next_at {
            let until = self.next_at.min(deadline);
            if until > now {
                match cancel {
                    Some(cancel) => {
                        cancel.wait(until - now);
                    }
                    None => std::thread::sleep(until - now),
                }
            }
            return false;
        }
        self.next_at = now + self.interval;
        true
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_retry_is_due_at_once_then_after_the_interval() {
        let mut retry = Retry::new(Duration::from_secs(3600));
        assert!(retry.due_or_wait(Instant::now(), None));
        assert!(
            !retry.due_or_wait(Instant::now(), None),
            "not again within the hour"
        );
        retry.now();
        assert!(
            retry.due_or_wait(Instant::now(), None),
            "due again once the port went away"
        );
    }
}
