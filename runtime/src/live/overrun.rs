//! Handlers that run too long. A heartbeat means "this service is responsive": a handler
//! that uses more CPU than the heartbeat deadline, or blocks past it, stops them, and the
//! broker counts it as a stall (that is how a hung service is found). When a handler takes
//! more than half of the deadline it runs under, the harness says so once per handler, with
//! what to do about it, so that a slow handler is seen before the broker kills the service
//! for it. `on_start` is measured on the wall clock, as its startup deadline is; every
//! other handler by the CPU it used, which a busy machine does not stretch.

use std::collections::BTreeSet;
use std::time::Duration;

/// Watches how long each handler of one service takes.
#[derive(Debug)]
pub(super) struct OverrunWatch {
    service: String,
    /// The deadline `on_start` runs under: the startup deadline.
    startup_deadline: Duration,
    /// The deadline every other handler runs under: the heartbeat deadline.
    heartbeat_deadline: Duration,
    warned: BTreeSet<&'static str>,
}

impl OverrunWatch {
    pub(super) fn new(
        service: &str,
        startup_deadline: Duration,
        heartbeat_deadline: Duration,
    ) -> Self {
        Self {
            service: service.to_owned(),
            startup_deadline,
            heartbeat_deadline,
            warned: BTreeSet::new(),
        }
    }

    /// Handler `handler` took `took`.
    pub(super) fn ran(&mut self, handler: &'static str, took: Duration) {
        if let Some(text) = self.judge(handler, took) {
            tracing::warn!(service = self.service, "{text}");
        }
    }

    /// The warning for a run of `took`, the first time a handler takes too long.
    fn judge(&mut self, handler: &'static str, took: Duration) -> Option<String> {
        let (deadline, which) = if handler == "on_start" {
            (self.startup_deadline, "startup")
        } else {
            (self.heartbeat_deadline, "heartbeat")
        };
        if took * 2 <= deadline || !self.warned.insert(handler) {
            return None;
        }
        Some(format!(
            "{}: {handler} took {} ms, more than half of its {which} deadline of {} ms; a \
             handler that uses more CPU than the deadline stops the heartbeats, and the broker \
             counts it as a stall: move long work or blocking device work into a device reader \
             (see Service::device)",
            self.service,
            took.as_millis(),
            deadline.as_millis()
        ))
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn a_handler_over_half_its_deadline_is_reported_once() {
        let mut watch = OverrunWatch::new(
            "laser",
            Duration::from_millis(5000),
            Duration::from_millis(100),
        );
        let ms = Duration::from_millis;
        assert_eq!(watch.judge("on_tick", ms(50)), None);
        let said = watch.judge("on_tick", ms(51)).unwrap();
        assert!(
            said.starts_with(
                "laser: on_tick took 51 ms, more than half of its heartbeat deadline of 100 ms"
            ),
            "{said}"
        );
        assert_eq!(watch.judge("on_tick", ms(80)), None);
        assert!(watch.judge("on_device", ms(80)).is_some());
        // on_start runs before the first heartbeat, under the startup deadline.
        assert_eq!(watch.judge("on_start", ms(2000)), None);
        assert!(
            watch
                .judge("on_start", ms(3000))
                .unwrap()
                .contains("startup deadline of 5000 ms")
        );
    }
}
