//! The hosts of a robot on more than one: a host lost takes its services with it, and
//! they come back only through the broker once the host joins again.

use super::service::{AfterStop, ServiceState};
use super::{Action, BrokerCore};
use lewis_robot::StartMode;

impl BrokerCore {
    /// The services that run on `host`, in boot order.
    fn services_on(&self, host: &str) -> Vec<String> {
        self.boot_order
            .iter()
            .filter(|name| {
                self.services
                    .get(name.as_str())
                    .is_some_and(|e| e.host.as_deref() == Some(host))
            })
            .cloned()
            .collect()
    }

    /// `host` cannot be reached: its services that ran are failed (no stop is sent, none
    /// would arrive; the host stops them itself once it has lost the broker), none of them
    /// may be chosen or started, and their bindings as clients go.
    pub(super) fn host_lost(&mut self, host: &str, why: &str) {
        let names = self.services_on(host);
        for name in &names {
            let Some(entry) = self.services.get_mut(name) else {
                continue;
            };
            if entry.host_down {
                continue;
            }
            entry.host_down = true;
            match entry.state {
                ServiceState::Idle | ServiceState::Stopped => continue,
                ServiceState::Stopping {
                    then: AfterStop::Stopped,
                } => {
                    entry.state = ServiceState::Stopped;
                    continue;
                }
                ServiceState::Failed { .. } => {
                    // Retried when its host is back, not by a cool-down that cannot reach it.
                    entry.state = ServiceState::Failed { retry_at_ns: None };
                    entry.lost_with_host = true;
                    continue;
                }
                ServiceState::Starting { .. }
                | ServiceState::Ready { .. }
                | ServiceState::Restarting { .. }
                | ServiceState::Stopping { .. } => {}
            }
            entry.state = ServiceState::Failed { retry_at_ns: None };
            entry.lost_with_host = true;
            let cause = format!("{name} runs on host {host}, which is lost: {why}");
            entry.last_failure = Some(cause.clone());
            self.decide(
                Action::ServiceFailed {
                    service: name.clone(),
                },
                format!(
                    "{cause}; its clients move, and it rejoins through the broker when {host} is back"
                ),
            );
        }
        for name in &names {
            self.client_gone(name);
        }
    }

    /// `host` can be reached (again): its services may be chosen; those that must run
    /// (always, or a hot standby) are started there, and those lost with it are idle
    /// again, started when a client needs them (or fails back to them, where configured).
    pub(super) fn host_joined(&mut self, host: &str) {
        for name in self.services_on(host) {
            let Some(entry) = self.services.get_mut(&name) else {
                continue;
            };
            entry.host_down = false;
            if entry.lost_with_host {
                entry.lost_with_host = false;
                entry.tracker.reset();
                entry.state = ServiceState::Idle;
            }
            if entry.state == ServiceState::Idle && entry.start != StartMode::OnDemand {
                let mode = match entry.start {
                    StartMode::Always => "it must always run",
                    _ => "it is a hot standby",
                };
                self.start(&name, format!("host {host} joined and {mode}"));
            }
        }
    }
}
