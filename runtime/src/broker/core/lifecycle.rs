//! How services live: started, ready, crashed and restarted, stalled, failed, stopped and
//! restarted by the operator, and the deadlines that drive it.

use super::decision::{fmt_span, fmt_time};
use super::service::{AfterStop, Probation, ServiceState, ms_to_ns};
use super::{Action, BrokerCore, ExitStatus, Need};
use crate::supervise::RestartDecision;
use lewis_robot::{OnCheckFailure, StartMode};
use lewis_service::Health;

impl BrokerCore {
    pub(super) fn boot(&mut self) {
        for name in self.boot_order.clone() {
            let Some(entry) = self.services.get(&name) else {
                continue;
            };
            // A service of a host not joined yet starts when it joins (`host_joined`).
            if entry.state == ServiceState::Idle
                && entry.start != StartMode::OnDemand
                && !entry.host_down
            {
                let mode = match entry.start {
                    StartMode::Always => "it must always run",
                    _ => "it is a hot standby",
                };
                self.start(&name, format!("the broker started and {mode}"));
            }
        }
    }

    /// A heartbeat (or, with `health` `None`, the first-heartbeat event).
    pub(super) fn heartbeat(&mut self, service: &str, health: Option<&Health>) {
        let now = self.now_ns;
        let Some(entry) = self.services.get_mut(service) else {
            return;
        };
        if matches!(
            entry.state,
            ServiceState::Starting { .. } | ServiceState::Ready { .. }
        ) {
            if entry.probation == Probation::Retried
                && let Some(retry) = self.retry
            {
                entry.probation = Probation::Until {
                    until_ns: now.saturating_add(ms_to_ns(retry.probation_ms)),
                };
            }
            entry.state = ServiceState::Ready {
                last_heartbeat_ns: now,
            };
            if let Some(health) = health {
                // A degradation the data showed stays until the process goes, whatever the
                // service says of itself; out of service still wins.
                entry.health = match (&entry.data_degraded, health) {
                    (Some(cause), Health::Ok) => Health::Degraded(cause.clone()),
                    _ => health.clone(),
                };
            }
        }
    }

    /// A service's own heartbeat thread says its loop is stuck: failed at once, as a stall
    /// past its deadline is. The thread says so only of a step already past the deadline,
    /// so waiting out another deadline of silence would judge the same stall twice.
    pub(super) fn loop_stuck(&mut self, service: &str, why: &str) {
        let ready = self
            .services
            .get(service)
            .is_some_and(|entry| matches!(entry.state, ServiceState::Ready { .. }));
        if ready {
            self.fail(service, &format!("{service} stalled: {why}"), true, true);
        }
    }

    /// A failed check of a provider's data: failed as a stall is, or degraded.
    pub(super) fn data_check_failed(
        &mut self,
        service: &str,
        interface: &str,
        check: &str,
        reason: &str,
    ) {
        let on_failure = self
            .on_check_failure
            .get(&(service.to_owned(), interface.to_owned()))
            .copied()
            .unwrap_or_default();
        // Only a running process's data counts: a late report about a process that has
        // gone since says nothing of the next one.
        let running = self.services.get(service).is_some_and(|e| {
            matches!(
                e.state,
                ServiceState::Starting { .. } | ServiceState::Ready { .. }
            )
        });
        if !running || self.waits_for_input(service, check, reason) {
            return;
        }
        let Some(entry) = self.services.get_mut(service) else {
            return;
        };
        let cause = format!("{service} failed its {check} check on {interface}: {reason}");
        match on_failure {
            OnCheckFailure::Failed => self.fail(service, &cause, true, true),
            OnCheckFailure::Degraded => {
                if entry.data_degraded.is_some() {
                    return;
                }
                entry.data_degraded = Some(cause.clone());
                if entry.health == Health::Ok {
                    entry.health = Health::Degraded(cause.clone());
                }
                self.decide(
                    Action::ServiceDegraded {
                        service: service.to_owned(),
                    },
                    format!("{cause}; the robot file says to degrade it: its clients stay"),
                );
            }
        }
    }

    pub(super) fn exited(&mut self, service: &str, status: ExitStatus) {
        let Some(entry) = self.services.get_mut(service) else {
            return;
        };
        match entry.state {
            ServiceState::Starting { .. } | ServiceState::Ready { .. } => {
                self.crashed(service, &format!("{service} exited with {status}"));
            }
            ServiceState::Stopping { then } => match then {
                AfterStop::Stopped => entry.state = ServiceState::Stopped,
                AfterStop::Failed { retry_at_ns } => {
                    entry.state = ServiceState::Failed { retry_at_ns };
                }
                AfterStop::Restart => {
                    self.start(service, format!("the operator restarts {service}"));
                }
            },
            // No process of ours: a late or duplicate report.
            ServiceState::Idle
            | ServiceState::Restarting { .. }
            | ServiceState::Stopped
            | ServiceState::Failed { .. } => {}
        }
    }

    pub(super) fn crashed(&mut self, service: &str, what: &str) {
        let now = self.now_ns;
        let Some(entry) = self.services.get_mut(service) else {
            return;
        };
        // A process restarted during its trial is on trial again from its start.
        if entry.probation != Probation::Passed {
            entry.probation = Probation::Retried;
        }
        match entry.tracker.on_failure(now) {
            RestartDecision::RestartAt { at_ns, attempt } => {
                entry.state = ServiceState::Restarting { at_ns, attempt };
                let max = entry.tracker.policy().max_restarts;
                let window_ms = entry.tracker.policy().window_ms;
                self.decide(
                    Action::RestartScheduled {
                        service: service.to_owned(),
                        at_ns,
                        attempt,
                    },
                    format!(
                        "{what}; restart {attempt} of at most {max} within {window_ms} ms, after {} of backoff; its clients stay bound",
                        fmt_time(at_ns.saturating_sub(now))
                    ),
                );
            }
            RestartDecision::GiveUp { failures } => {
                let window_ms = entry.tracker.policy().window_ms;
                self.fail(
                    service,
                    &format!("{what}, its failure {failures} within {window_ms} ms: beyond its restart policy"),
                    true,
                    false,
                );
            }
        }
    }

    pub(super) fn start_failed(&mut self, service: &str, error: &str) {
        let Some(entry) = self.services.get(service) else {
            return;
        };
        if matches!(entry.state, ServiceState::Starting { .. }) {
            self.fail(
                service,
                &format!("{service} could not be started ({error})"),
                false,
                false,
            );
        }
    }

    /// Marks a service failed for good; stops its process if it still has one
    /// (`process_alive`: it stalled, rather than exited or never started).
    pub(super) fn fail(&mut self, service: &str, cause: &str, retry: bool, process_alive: bool) {
        let now = self.now_ns;
        let policy = self.retry;
        let Some(entry) = self.services.get_mut(service) else {
            return;
        };
        // A retry that failed on trial doubles the next cool-down.
        if entry.probation != Probation::Passed {
            entry.retries = entry.retries.saturating_add(1);
            entry.probation = Probation::Passed;
        }
        let cool_down_ms = policy
            .filter(|_| retry)
            .map(|p| p.cool_down_ms(entry.retries));
        let retry_at_ns = cool_down_ms.map(|ms| now.saturating_add(ms_to_ns(ms)));
        entry.state = if process_alive {
            ServiceState::Stopping {
                then: AfterStop::Failed { retry_at_ns },
            }
        } else {
            ServiceState::Failed { retry_at_ns }
        };
        entry.last_failure = Some(cause.to_owned());
        let always = entry.start == StartMode::Always;
        let retries = entry.retries;
        // In how long, not at what time: a live broker's clock reads nanoseconds since 1970.
        let retry_note = match cool_down_ms {
            Some(ms) if retries > 0 => format!(
                "; it will be retried in {} (longer each time a retry fails on trial: {retries} so far)",
                fmt_span(ms_to_ns(ms))
            ),
            Some(ms) => format!("; it will be retried in {}", fmt_span(ms_to_ns(ms))),
            None if !retry => {
                "; not retried, it would fail the same way: fix it, then restart it".to_owned()
            }
            None => String::new(),
        };
        self.decide(
            Action::ServiceFailed {
                service: service.to_owned(),
            },
            format!("{cause}{retry_note}"),
        );
        if process_alive {
            self.decide(
                Action::Stop {
                    service: service.to_owned(),
                },
                format!("{service} has failed: its process must go"),
            );
        }
        if always {
            self.decide(
                Action::AskForHelp {
                    need: Need::Service(service.to_owned()),
                },
                format!("{service} must always run and has failed: {cause}"),
            );
        }
    }

    pub(super) fn start(&mut self, service: &str, reason: String) {
        let now = self.now_ns;
        let Some(entry) = self.services.get_mut(service) else {
            return;
        };
        if matches!(entry.state, ServiceState::Restarting { .. }) {
            entry.restarts = entry.restarts.saturating_add(1);
        }
        entry.state = ServiceState::Starting { since_ns: now };
        entry.health = Health::Ok;
        entry.data_degraded = None;
        entry.waiting_for = None;
        self.decide(
            Action::Start {
                service: service.to_owned(),
            },
            reason,
        );
    }

    pub(super) fn operator_stop(&mut self, service: &str) {
        let Some(entry) = self.services.get_mut(service) else {
            return;
        };
        match entry.state {
            ServiceState::Starting { .. } | ServiceState::Ready { .. } => {
                entry.state = ServiceState::Stopping {
                    then: AfterStop::Stopped,
                };
                self.decide(
                    Action::Stop {
                        service: service.to_owned(),
                    },
                    format!("the operator stops {service}"),
                );
            }
            ServiceState::Stopping { .. } => {
                entry.state = ServiceState::Stopping {
                    then: AfterStop::Stopped,
                };
            }
            ServiceState::Idle
            | ServiceState::Restarting { .. }
            | ServiceState::Failed { .. }
            | ServiceState::Stopped => entry.state = ServiceState::Stopped,
        }
    }

    pub(super) fn operator_restart(&mut self, service: &str) {
        let Some(entry) = self.services.get_mut(service) else {
            return;
        };
        // The operator vouches for it: no trial, no escalated cool-down.
        entry.tracker.reset();
        entry.probation = Probation::Passed;
        entry.retries = 0;
        match entry.state {
            ServiceState::Starting { .. } | ServiceState::Ready { .. } => {
                entry.state = ServiceState::Stopping {
                    then: AfterStop::Restart,
                };
                self.decide(
                    Action::Stop {
                        service: service.to_owned(),
                    },
                    format!("the operator restarts {service}: stop it first"),
                );
            }
            ServiceState::Stopping { .. } => {
                entry.state = ServiceState::Stopping {
                    then: AfterStop::Restart,
                };
            }
            ServiceState::Idle
            | ServiceState::Restarting { .. }
            | ServiceState::Failed { .. }
            | ServiceState::Stopped => {
                self.start(service, format!("the operator restarts {service}"));
            }
        }
    }

    /// Acts on every deadline at or before now, earliest first (then by name). Each step
    /// leaves the service with a later deadline or none, so this ends.
    pub(super) fn run_deadlines(&mut self) {
        let now = self.now_ns;
        while let Some((_, name)) = self
            .services
            .iter()
            .filter_map(|(name, e)| e.deadline().map(|d| (d, name)))
            .filter(|(d, _)| *d <= now)
            .min()
            .map(|(d, name)| (d, name.clone()))
        {
            self.deadline_reached(&name);
        }
    }

    pub(super) fn deadline_reached(&mut self, service: &str) {
        let Some(entry) = self.services.get_mut(service) else {
            return;
        };
        match entry.state {
            ServiceState::Starting { .. } => {
                let ms = entry.startup_deadline_ns / 1_000_000;
                self.fail(
                    service,
                    &format!("{service} stalled: no first heartbeat within its startup deadline of {ms} ms"),
                    true,
                    true,
                );
            }
            ServiceState::Ready { last_heartbeat_ns } => {
                let stalled =
                    last_heartbeat_ns.saturating_add(entry.heartbeat_deadline_ns) <= self.now_ns;
                if !stalled {
                    // Its probation is over and it stayed up: clients may fail back to it
                    // (`reconcile`), and its next failure starts the cool-downs afresh.
                    entry.probation = Probation::Passed;
                    entry.retries = 0;
                    return;
                }
                let ms = entry.heartbeat_deadline_ns / 1_000_000;
                // How long it was silent says whether it died or the machine was held up.
                let silent_ms = (self.now_ns - last_heartbeat_ns) / 1_000_000;
                self.fail(
                    service,
                    &format!(
                        "{service} stalled: no heartbeat for {silent_ms} ms (its deadline: {ms} ms)"
                    ),
                    true,
                    true,
                );
            }
            ServiceState::Restarting { attempt, .. } => {
                self.start(
                    service,
                    format!("restart {attempt} of {service} after its backoff"),
                );
            }
            ServiceState::Failed { .. } => {
                entry.tracker.reset();
                entry.probation = Probation::Retried;
                let note = self.retry.map_or_else(String::new, |p| {
                    format!(
                        "; clients fail back to it once it has stayed up {}",
                        fmt_span(ms_to_ns(p.probation_ms))
                    )
                });
                self.start(
                    service,
                    format!("retry {service}, failed long enough ago{note}"),
                );
            }
            ServiceState::Idle | ServiceState::Stopping { .. } | ServiceState::Stopped => {}
        }
    }
}
