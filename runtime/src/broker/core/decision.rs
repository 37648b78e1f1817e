//! What the decision core decides: actions for the driver, each with its reason.

use std::fmt;

use serde::{Deserialize, Serialize};

/// One thing the broker decided to do.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Action {
    /// Spawn the service's process.
    Start {
        /// The service.
        service: String,
    },
    /// Stop the service's process (SIGTERM, then SIGKILL after a grace period); a
    /// `ProcessExited` event is expected back.
    Stop {
        /// The service.
        service: String,
    },
    /// Tell a client which service provides the interface it asked for.
    Bind {
        /// The client.
        client: String,
        /// The interface.
        interface: String,
        /// Its provider.
        service: String,
    },
    /// Move a client to another provider of an interface.
    Rebind {
        /// The client.
        client: String,
        /// The interface.
        interface: String,
        /// The provider it leaves.
        from: String,
        /// The provider it gets.
        to: String,
    },
    /// A client has no provider for an interface any more (it keeps waiting for one).
    Unbind {
        /// The client.
        client: String,
        /// The interface.
        interface: String,
        /// The provider it loses.
        service: String,
    },
    /// A client asked for an interface that no service of the robot provides.
    Reject {
        /// The client.
        client: String,
        /// The interface.
        interface: String,
    },
    /// Nothing the broker can do keeps the robot whole: a person should look.
    AskForHelp {
        /// What is missing.
        need: Need,
    },
    /// A record only (the driver has nothing to do): a crashed service will be started
    /// again at `at_ns`; its clients stay bound to it.
    RestartScheduled {
        /// The service.
        service: String,
        /// When it will be started.
        at_ns: i64,
        /// Which restart within its policy's window, from 1.
        attempt: u32,
    },
    /// A record only: a check of the service's data failed and the robot file says to
    /// degrade it rather than fail it; its clients stay bound.
    ServiceDegraded {
        /// The service.
        service: String,
    },
    /// A record only: the service failed for good (beyond its restart policy, stalled, or
    /// could not be started); it is not chosen again until retried or restarted.
    ServiceFailed {
        /// The service.
        service: String,
    },
    /// A record only: the service fell silent because an input of its own has no provider
    /// that serves; it is not failed for that silence (the reason names the root cause),
    /// keeps its clients and process, and its data is not judged until the input is back.
    ServiceWaiting {
        /// The service.
        service: String,
        /// The input it waits for.
        interface: String,
    },
    /// A record only: a waiting service's input is served again; its data is judged again.
    ServiceResumed {
        /// The service.
        service: String,
    },
}

/// What the broker needs help with.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Need {
    /// Clients wait for this interface and no provider of it is left.
    Interface(String),
    /// This service must always run and has failed for good.
    Service(String),
}

impl Action {
    /// Whether the live driver has something to carry out (the others are records).
    #[must_use]
    pub fn is_for_driver(&self) -> bool {
        !matches!(
            self,
            Self::RestartScheduled { .. }
                | Self::ServiceFailed { .. }
                | Self::ServiceDegraded { .. }
                | Self::ServiceWaiting { .. }
                | Self::ServiceResumed { .. }
        )
    }
}

/// An action, when it was decided, and why; published on `/lewis/broker`.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Decision {
    /// The time of the event that led to it, in nanoseconds.
    pub at_ns: i64,
    /// What to do.
    pub action: Action,
    /// Why, for people.
    pub reason: String,
}

impl fmt::Display for Action {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Start { service } => write!(f, "start {service}"),
            Self::Stop { service } => write!(f, "stop {service}"),
            Self::Bind {
                client,
                interface,
                service,
            } => write!(f, "bind {client} to {service} for {interface}"),
            Self::Rebind {
                client,
                interface,
                from,
                to,
            } => write!(f, "rebind {client} from {from} to {to} for {interface}"),
            Self::Unbind {
                client,
                interface,
                service,
            } => write!(f, "unbind {client} from {service} for {interface}"),
            Self::Reject { client, interface } => {
                write!(f, "reject {client}'s request for {interface}")
            }
            Self::AskForHelp {
                need: Need::Interface(interface),
            } => write!(f, "ask for help with {interface}"),
            Self::AskForHelp {
                need: Need::Service(service),
            } => write!(f, "ask for help with service {service}"),
            // No time: the decision is stamped when it is made, and its reason says how
            // long the backoff is (an absolute clock reading helps nobody).
            Self::RestartScheduled {
                service, attempt, ..
            } => write!(f, "restart {service} (attempt {attempt})"),
            Self::ServiceFailed { service } => write!(f, "{service} failed"),
            Self::ServiceDegraded { service } => write!(f, "{service} degraded"),
            Self::ServiceWaiting { service, interface } => {
                write!(f, "{service} waits for {interface}")
            }
            Self::ServiceResumed { service } => write!(f, "{service} resumed"),
        }
    }
}

impl fmt::Display for Decision {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        write!(f, "{}: {}", self.action, self.reason)
    }
}

/// A time or duration for people: whole milliseconds when it is one, nanoseconds otherwise.
pub(super) fn fmt_time(ns: i64) -> String {
    if ns % 1_000_000 == 0 {
        format!("{} ms", ns / 1_000_000)
    } else {
        format!("{ns} ns")
    }
}

/// A span of nanoseconds as a person reads it, for a live clock's times as how long ago
/// or how soon: `300 ms`, `20 s`, `4.2 s`, `3 min 20 s`.
pub(super) fn fmt_span(ns: i64) -> String {
    let ms = ns.max(0) / 1_000_000;
    if ms < 1000 {
        format!("{ms} ms")
    } else if ms < 60_000 && ms % 1000 == 0 {
        format!("{} s", ms / 1000)
    } else if ms < 60_000 {
        format!("{:.1} s", ms as f64 / 1000.0)
    } else {
        format!("{} min {} s", ms / 60_000, (ms % 60_000) / 1000)
    }
}

/// Thousandths of a core as a person reads them: `18%`, `2.5%`, `150%`.
pub(super) fn fmt_cpu(milli_cores: u32) -> String {
    if milli_cores.is_multiple_of(10) {
        format!("{}%", milli_cores / 10)
    } else {
        format!("{}.{}%", milli_cores / 10, milli_cores % 10)
    }
}
