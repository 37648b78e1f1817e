//! One service as the decision core sees it: its offers, its state, its declared health
//! and its failure history.

use std::collections::BTreeMap;

use serde::{Deserialize, Serialize};

use crate::supervise::RestartTracker;
use lewis_robot::{ServiceSpec, StartMode};
use lewis_service::Health;

/// Where a service is in its life, as the broker sees it.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ServiceState {
    /// Not started yet; it can be started on demand.
    Idle,
    /// Started at `since_ns`; waiting for its first heartbeat.
    Starting {
        /// When the start was ordered.
        since_ns: i64,
    },
    /// Sending heartbeats.
    Ready {
        /// When the last one arrived.
        last_heartbeat_ns: i64,
    },
    /// Crashed; it will be started again at `at_ns` and keeps its clients meanwhile.
    Restarting {
        /// When it will be started.
        at_ns: i64,
        /// Which restart within its policy's window, from 1.
        attempt: u32,
    },
    /// Asked to stop; waiting for its process to end.
    Stopping {
        /// What follows once it has ended.
        then: AfterStop,
    },
    /// Stopped by the operator; not chosen until the operator restarts it.
    Stopped,
    /// Failed for good; not chosen until retried (at `retry_at_ns`) or restarted by the operator.
    Failed {
        /// When it will be started again, if the robot says failed services are retried.
        retry_at_ns: Option<i64>,
    },
}

/// What follows the end of a process the broker stopped.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum AfterStop {
    /// It stays stopped (operator stop).
    Stopped,
    /// It is started again (operator restart); clients stay bound.
    Restart,
    /// It is failed (it stalled); clients have already been moved.
    Failed {
        /// When it will be started again, if failed services are retried.
        retry_at_ns: Option<i64>,
    },
}

/// What a service offers for one interface.
#[derive(Debug, Clone, Copy, PartialEq)]
pub(super) struct Offer {
    pub quality: u32,
    pub cost: u32,
    /// The rate it publishes at, when the robot file says.
    pub rate_hz: Option<f64>,
}

#[derive(Debug, Clone)]
pub(super) struct Entry {
    pub start: StartMode,
    pub offers: BTreeMap<String, Offer>,
    pub heartbeat_deadline_ns: i64,
    pub startup_deadline_ns: i64,
    pub tracker: RestartTracker,
    pub state: ServiceState,
    pub health: Health,
    pub restarts: u32,
    pub last_failure: Option<String>,
    /// Why a data check degraded the current process, if one did.
    pub data_degraded: Option<String>,
    /// The input whose absence silenced the current process, while it waits for it (see
    /// [`Action::ServiceWaiting`](super::Action::ServiceWaiting)).
    pub waiting_for: Option<String>,
    /// Retries that failed again before passing their probation: the cool-down's doubling.
    pub retries: u32,
    /// Whether a retried service has yet to prove itself.
    pub probation: Probation,
    /// The group of services it excludes (one device): clients are bound to at most one.
    pub excludes: Option<String>,
    /// What it is taken to use of the CPU until measured, in thousandths of a core.
    pub declared_milli_cores: u32,
    /// What it was measured to use, smoothed, in thousandths of a core; `None` until its
    /// process was first measured.
    pub measured_milli_cores: Option<u32>,
    /// The host it runs on, for a robot on more than one.
    pub host: Option<String>,
    /// Whether its host is unreachable: it can neither serve nor be started.
    pub host_down: bool,
    /// Whether it failed because its host was lost: it rejoins when the host is back.
    pub lost_with_host: bool,
}

/// A retried service's trial: clients fail back to it only once it has stayed up.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub(super) enum Probation {
    /// Not on trial: an ordinary service, or one that passed.
    Passed,
    /// Retried; its process has not reported ready yet (or crashed and is restarted).
    Retried,
    /// Ready; on trial until `until_ns`.
    Until {
        /// When it has stayed up long enough.
        until_ns: i64,
    },
}

/// Milliseconds as nanoseconds; saturating, and at least 1 ns so that every deadline is
/// strictly after the time it is set.
pub(super) fn ms_to_ns(ms: u64) -> i64 {
    i64::try_from(ms.saturating_mul(1_000_000))
        .unwrap_or(i64::MAX)
        .max(1)
}

impl Entry {
    pub fn new(spec: &ServiceSpec) -> Self {
        Self {
            start: spec.start,
            offers: spec
                .provides
                .iter()
                .map(|p| {
                    (
                        p.interface.clone(),
                        Offer {
                            quality: p.quality,
                            cost: p.cost,
                            rate_hz: p.data_rate_hz,
                        },
                    )
                })
                .collect(),
            heartbeat_deadline_ns: ms_to_ns(spec.heartbeat_deadline_ms),
            startup_deadline_ns: ms_to_ns(spec.startup_deadline_ms),
            tracker: RestartTracker::new(spec.restart),
            state: ServiceState::Idle,
            health: Health::Ok,
            restarts: 0,
            last_failure: None,
            data_degraded: None,
            waiting_for: None,
            retries: 0,
            probation: Probation::Passed,
            excludes: spec.excludes.clone(),
            declared_milli_cores: spec.declared_cpu_percent().saturating_mul(10),
            measured_milli_cores: None,
            host: None,
            host_down: false,
            lost_with_host: false,
        }
    }

    /// What it uses of the CPU, in thousandths of a core: measured when it was, declared
    /// otherwise.
    pub fn milli_cores(&self) -> u32 {
        self.measured_milli_cores
            .unwrap_or(self.declared_milli_cores)
    }

    /// Takes a measurement of its CPU into the smoothed one: an exponential average that
    /// gives each new measurement a quarter of the weight, so that one busy second (a
    /// start, a burst of frames) does not turn the choice of providers over; the first
    /// measurement is taken as it is. Integer arithmetic: replay must get the same.
    pub fn measured(&mut self, milli_cores: u32) {
        self.measured_milli_cores = Some(match self.measured_milli_cores {
            None => milli_cores,
            Some(old) => {
                let old = i64::from(old);
                let new = old + (i64::from(milli_cores) - old) / 4;
                u32::try_from(new).unwrap_or(u32::MAX)
            }
        });
    }

    /// Whether a process of this service exists (or is being spawned).
    #[cfg(test)]
    pub fn has_process(&self) -> bool {
        matches!(
            self.state,
            ServiceState::Starting { .. }
                | ServiceState::Ready { .. }
                | ServiceState::Stopping { .. }
        )
    }

    /// Whether a process runs or will run again without a new decision: such a service
    /// costs no new process when chosen.
    pub fn is_active(&self) -> bool {
        matches!(
            self.state,
            ServiceState::Starting { .. }
                | ServiceState::Ready { .. }
                | ServiceState::Restarting { .. }
                | ServiceState::Stopping {
                    then: AfterStop::Restart
                }
        )
    }

    /// Whether clients may stay bound to it: running or coming back, and not out of service.
    pub fn serves(&self) -> bool {
        self.is_active() && !self.health.is_out_of_service() && !self.host_down
    }

    /// Whether it may be chosen for a new binding (perhaps by starting it).
    pub fn can_serve(&self) -> bool {
        self.serves()
            || (self.state == ServiceState::Idle
                && !self.health.is_out_of_service()
                && !self.host_down)
    }

    /// Whether it is ready now and not out of service.
    pub fn ready_to_serve(&self) -> bool {
        matches!(self.state, ServiceState::Ready { .. }) && !self.health.is_out_of_service()
    }

    /// Whether clients may fail back to it: ready, and not a retried service on trial.
    pub fn proven(&self) -> bool {
        self.ready_to_serve() && self.probation == Probation::Passed
    }

    /// When a retried service's probation ends, while it is on trial.
    pub fn probation_until_ns(&self) -> Option<i64> {
        match self.probation {
            Probation::Until { until_ns } => Some(until_ns),
            Probation::Passed | Probation::Retried => None,
        }
    }

    /// When the core must next look at this service without being told.
    pub fn deadline(&self) -> Option<i64> {
        match self.state {
            ServiceState::Starting { since_ns } => {
                Some(since_ns.saturating_add(self.startup_deadline_ns))
            }
            ServiceState::Ready { last_heartbeat_ns } => {
                let stall = last_heartbeat_ns.saturating_add(self.heartbeat_deadline_ns);
                Some(
                    self.probation_until_ns()
                        .map_or(stall, |end| end.min(stall)),
                )
            }
            ServiceState::Restarting { at_ns, .. } => Some(at_ns),
            ServiceState::Failed { retry_at_ns } => retry_at_ns,
            ServiceState::Idle | ServiceState::Stopping { .. } | ServiceState::Stopped => None,
        }
    }
}
