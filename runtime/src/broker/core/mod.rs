//! The broker's decision core: a pure state machine. Events come in with their time,
//! decisions come out; no I/O, no clock, no randomness, and every map is ordered, so the
//! same event sequence always gives the same decisions (live and in replay).
//!
//! Policy (DESIGN.md, "The broker"):
//! - A client asks for an interface. It is bound to the best provider that can serve:
//!   highest quality first; at equal quality a provider whose process already runs (it
//!   costs no new process: the joint choice across interfaces, see below); then lower
//!   cost; then name. A provider that is not running is started on demand and the client is
//!   bound to it at once, so it subscribes while the process comes up.
//! - A provider that crashes (any exit the broker did not ask for, code 0 included) is
//!   restarted within its [`RestartPolicy`](lewis_robot::RestartPolicy); its clients stay
//!   bound meanwhile. Beyond the policy it has failed: its clients are rebound to the next
//!   provider, started if needed.
//! - A provider that misses its heartbeat deadline (or its startup deadline) has stalled: it
//!   has failed, it is stopped (the driver kills it) and its clients are rebound at once.
//! - A provider whose published data fails a check (the broker's health module: rate,
//!   freshness, values, frozen) has failed as a stalled one has (stopped, clients rebound at
//!   once, retried as configured), or, where the robot file says `on_failure =
//!   "degraded"`, is degraded: recorded and shown, its clients stay.
//! - A provider that declares itself out of service loses its clients at once, but its
//!   process is kept: it knows best when it recovers (a blocked laser), keeps sending
//!   heartbeats (so a stall is still seen), and becomes a candidate again when it declares
//!   itself healthy. A degraded provider keeps its clients: degraded is recorded and shown.
//! - A provider that cannot be spawned at all (its program does not exist) has failed at
//!   once and is never retried by the broker: it would fail the same way forever.
//! - Fail back (per robot, per interface): when a provider that is ready and healthy is
//!   strictly better (higher quality, or equal quality and lower cost) than a client's
//!   current one, the client is moved to it. Only ready providers are failed back to, so a
//!   client never leaves a working provider for one that has not proven itself.
//! - When a client's interface has no provider left, the client is unbound and the broker
//!   asks for help, once per outage; the client stays waiting and is bound as soon as a
//!   provider can serve again (operator restart, retry, recovery from out of service).
//! - When `retry_failed_after_ms` is set, a service that failed by crashing or stalling is
//!   started again after that cool-down, with its restart history forgotten. It is then on
//!   probation (`retry_probation_ms`): it serves clients that have no provider at once,
//!   but clients fail back to it only once it has stayed up through its probation. Each
//!   retry that fails again before that doubles the next cool-down, up to
//!   `retry_failed_max_ms`; a probation passed starts it again from the first.
//! - `standby` and `always` services start with the broker; an `always` service that fails
//!   for good also asks for help. Services started on demand keep running when their
//!   clients leave, as warm standbys, until the operator stops them.
//!
//! - A provider that falls silent because an input of its own has no provider that serves
//!   is not failed for it: it waits for its input, keeps its clients, and the decision
//!   names the root cause ([`waiting`]).
//!
//! Joint choice ([`plan`]): each time clients need a decision (a new client, a provider
//! that failed, one to fail back to), every client's interface is given its provider
//! together with the others. The robot file may constrain the set: a CPU budget (the
//! services' CPU as measured, [`Event::CpuMeasured`], or declared until measured), groups
//! of services that exclude each other (one pan-tilt), and the least data rate a client
//! needs. The choice keeps as many constraints as it can, then takes the highest quality,
//! then starts the least CPU, preferring a process that already runs (a base giving
//! Synchrodrive, Power and a sonar RangeFinder is reused rather than a new process
//! started). Clients whose provider serves are not moved, except to fail back or, when no
//! other choice keeps a constraint, to keep it; the reason says which.
//!
//! Deadlines: [`BrokerCore::handle`] first acts on every deadline at or before `now_ns`
//! (so a heartbeat arriving exactly at or after its deadline is late), then on the event,
//! then on any deadline the event made due, then rebinds clients.

mod bindings;
mod decision;
mod event;
mod hosts;
mod lifecycle;
mod plan;
mod service;
mod snapshot;
mod waiting;

#[cfg(test)]
mod proptests;
#[cfg(test)]
mod tests;

use std::collections::{BTreeMap, BTreeSet};

pub use decision::{Action, Decision, Need};
pub use event::{Event, ExitStatus};
pub use service::{AfterStop, ServiceState};
pub use snapshot::{Binding, ServiceStatus, Snapshot};

use service::Entry;

use lewis_robot::{OnCheckFailure, RetryPolicy, Robot};

/// The broker's decision core. Build it from a robot description with [`BrokerCore::new`],
/// feed it [`Event`]s with [`BrokerCore::handle`], wake it at [`BrokerCore::next_deadline`].
#[derive(Debug, Clone)]
pub struct BrokerCore {
    services: BTreeMap<String, Entry>,
    /// Declaration order: the order in which services start with the broker.
    boot_order: Vec<String>,
    fail_back_default: bool,
    fail_back: BTreeMap<String, bool>,
    retry: Option<RetryPolicy>,
    /// What a failed data check does, per provider and interface (the robot file's
    /// `checks`).
    on_check_failure: BTreeMap<(String, String), OnCheckFailure>,
    /// Client, then interface, then its provider (`None` while it waits for one).
    clients: BTreeMap<String, BTreeMap<String, Option<String>>>,
    /// Interfaces for which help was asked and no provider came back since.
    help_asked: BTreeSet<String>,
    /// The least data rate a client needs of an interface (client, interface), from the
    /// robot file's `requires` of the service the client is.
    min_rates_hz: BTreeMap<(String, String), f64>,
    /// The robot's CPU budget in thousandths of a core, when it has one.
    cpu_budget_milli_cores: Option<u32>,
    out: Vec<Decision>,
    now_ns: i64,
}

impl BrokerCore {
    /// A core for this robot, before any event: no service runs, no client is known.
    #[must_use]
    pub fn new(robot: &Robot) -> Self {
        Self {
            services: robot
                .services
                .iter()
                .map(|spec| {
                    let mut entry = Entry::new(spec);
                    entry.host = robot.host_of(&spec.name).map(str::to_owned);
                    // The other hosts start lost: their services wait for their host to
                    // join (`Event::HostJoined`).
                    entry.host_down =
                        entry.host.as_deref() != robot.robot_host().map(|h| h.name.as_str());
                    (spec.name.clone(), entry)
                })
                .collect(),
            boot_order: robot.services.iter().map(|s| s.name.clone()).collect(),
            fail_back_default: robot.broker.fail_back,
            fail_back: robot.broker.fail_back_per_interface.clone(),
            retry: robot.broker.retry,
            on_check_failure: robot
                .services
                .iter()
                .flat_map(|s| s.provides.iter().map(move |p| (s, p)))
                .map(|(s, p)| {
                    let checks = robot.broker.checks_of(p);
                    ((s.name.clone(), p.interface.clone()), checks.on_failure)
                })
                .collect(),
            clients: BTreeMap::new(),
            help_asked: BTreeSet::new(),
            min_rates_hz: robot
                .services
                .iter()
                .flat_map(|s| {
                    s.min_rates_hz
                        .iter()
                        .map(move |(i, hz)| ((s.name.clone(), i.clone()), *hz))
                })
                .collect(),
            cpu_budget_milli_cores: robot
                .broker
                .cpu_budget_percent
                .map(|p| p.saturating_mul(10)),
            out: Vec::new(),
            now_ns: 0,
        }
    }

    /// Acts on an event that happened at `now_ns` and returns the decisions, in the order
    /// the driver must carry them out. Events about services the robot does not have are
    /// ignored.
    pub fn handle(&mut self, now_ns: i64, event: &Event) -> Vec<Decision> {
        self.now_ns = now_ns;
        // A host lost is what its services' deadlines at this instant stand for: judged
        // first, they would be failed as stalled, each with its own restart and stop.
        if !matches!(event, Event::HostLost { .. }) {
            self.run_deadlines();
        }
        self.apply(event);
        self.run_deadlines();
        self.reconcile();
        self.update_waiting();
        std::mem::take(&mut self.out)
    }

    /// The earliest time at which the core must be called (with [`Event::TimePassed`]) even
    /// if nothing else happens: a heartbeat or startup deadline, a restart after backoff, a
    /// retry of a failed service.
    #[must_use]
    pub fn next_deadline(&self) -> Option<i64> {
        self.services.values().filter_map(Entry::deadline).min()
    }

    /// The services whose deadline is at or before `now_ns`.
    #[must_use]
    pub fn due_services(&self, now_ns: i64) -> Vec<&str> {
        self.services
            .iter()
            .filter(|(_, e)| e.deadline().is_some_and(|d| d <= now_ns))
            .map(|(name, _)| name.as_str())
            .collect()
    }

    /// Whether `service`'s published data is to be checked now: it is ready, not out of
    /// service (a provider that says it cannot serve is expected to fall silent) and not
    /// waiting for an input of its own ([`Action::ServiceWaiting`]).
    #[must_use]
    pub fn data_is_judged(&self, service: &str) -> bool {
        self.services
            .get(service)
            .is_some_and(|e| e.ready_to_serve() && e.waiting_for.is_none())
    }

    /// When `service`'s last heartbeat was taken, while it is ready.
    #[must_use]
    pub fn last_heartbeat_ns(&self, service: &str) -> Option<i64> {
        match self.services.get(service)?.state {
            ServiceState::Ready { last_heartbeat_ns } => Some(last_heartbeat_ns),
            _ => None,
        }
    }

    /// Whether `service` crashed and its restart is scheduled, not yet made.
    #[must_use]
    pub fn restart_pending(&self, service: &str) -> bool {
        self.services
            .get(service)
            .is_some_and(|e| matches!(e.state, ServiceState::Restarting { .. }))
    }

    /// Whether the robot has a service with this name (for the operator's commands).
    #[must_use]
    pub fn has_service(&self, name: &str) -> bool {
        self.services.contains_key(name)
    }

    fn decide(&mut self, action: Action, reason: String) {
        self.out.push(Decision {
            at_ns: self.now_ns,
            action,
            reason,
        });
    }

    fn apply(&mut self, event: &Event) {
        match event {
            Event::BrokerStarted => self.boot(),
            Event::ClientRequest { client, interface } => self.request(client, interface),
            Event::ClientGone { client } => self.client_gone(client),
            // Spawned, not yet ready: the startup deadline keeps running.
            Event::ProviderStarted { .. } | Event::TimePassed => {}
            Event::ProviderReady { service } => self.heartbeat(service, None),
            Event::Heartbeat { service, health } => self.heartbeat(service, Some(health)),
            Event::LoopStuck { service, why } => self.loop_stuck(service, why),
            Event::HostLost { host, why } => self.host_lost(host, why),
            Event::HostJoined { host } => self.host_joined(host),
            Event::ProcessExited { service, status } => self.exited(service, *status),
            Event::StartFailed { service, error } => self.start_failed(service, error),
            Event::StopService { service } => self.operator_stop(service),
            Event::RestartService { service } => self.operator_restart(service),
            Event::DataCheckFailed {
                service,
                interface,
                check,
                reason,
            } => self.data_check_failed(service, interface, check, reason),
            Event::CpuMeasured {
                service,
                milli_cores,
            } => {
                if let Some(entry) = self.services.get_mut(service) {
                    entry.measured(*milli_cores);
                }
            }
        }
    }
}
