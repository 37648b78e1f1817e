//! The broker's data checks in the harness: every provider's publications (fed from the
//! recording or re-simulated, after the injected faults) go through the same
//! [`DataMonitor`]s as live, at the virtual time, so a garbage, frozen or slow provider
//! fails over here as it would live, and the same replay decides the same.
//!
//! As live, a provider is judged while the broker core has it ready and not out of service,
//! from the first sample after that, and reported once per run of its process. Freshness is
//! not judged: see [`Lockstep::check_data`].

use lewis_interfaces::cdr;
use lewis_runtime::broker::Event;
use lewis_runtime::broker::health::DataMonitor;

use super::Lockstep;
use super::engine::Work;

/// The watch of one provider's channel of one interface.
#[derive(Debug)]
pub(super) enum Watch {
    /// Judged: its samples go through the checks.
    Judging(Box<DataMonitor>),
    /// A check failed and was reported: nothing more until the provider's next run.
    Failed,
}

impl Lockstep<'_> {
    /// Judges one publication of `provider` on `interface` at the virtual time; a failed
    /// check goes to the broker core.
    pub(super) fn check_data(&mut self, provider: &str, interface: &str, bytes: &[u8]) {
        let key = (provider.to_owned(), interface.to_owned());
        if !self.core.data_is_judged(provider) {
            self.watches.remove(&key);
            return;
        }
        let Some(spec) = self.robot.service(provider) else {
            return;
        };
        let Some(provision) = spec.provision(interface) else {
            return;
        };
        let mut checks = self.robot.broker.checks_of(provision);
        // A recording's times are the publisher's and the recorder's (or an import's), not
        // the live broker's: they say nothing of how late the broker saw a sample.
        checks.freshness_ms = None;
        if !checks.any() {
            return;
        }
        let now_ns = self.now_ns;
        let watch = self.watches.entry(key).or_insert_with(|| {
            let rate = provision.data_rate_hz;
            Watch::Judging(Box::new(DataMonitor::new(interface, checks, rate, now_ns)))
        });
        let Watch::Judging(monitor) = watch else {
            return;
        };
        let publish_ns = cdr::peek_header(bytes).map_or(now_ns, |h| h.publish_time_ns);
        if let Err(failure) = monitor.sample(now_ns, publish_ns, bytes) {
            *watch = Watch::Failed;
            self.work.push_back(Work::Broker(Event::DataCheckFailed {
                service: provider.to_owned(),
                interface: interface.to_owned(),
                check: failure.check.as_str().to_owned(),
                reason: failure.reason,
            }));
        }
    }
}
