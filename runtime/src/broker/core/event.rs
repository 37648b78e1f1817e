//! What the decision core hears about: clients, provider processes, heartbeats, time and
//! the operator.

use std::fmt;

use serde::{Deserialize, Serialize};

use lewis_service::Health;

/// How a process ended.
#[derive(Debug, Clone, Copy, PartialEq, Eq, Serialize, Deserialize)]
pub enum ExitStatus {
    /// It exited with this code.
    Code(i32),
    /// It was killed by this signal.
    Signal(i32),
}

impl From<crate::supervise::ExitStatus> for ExitStatus {
    /// How the supervisor saw a process end, as the broker counts it.
    fn from(status: crate::supervise::ExitStatus) -> Self {
        match status {
            crate::supervise::ExitStatus::Exited { code } => Self::Code(code),
            crate::supervise::ExitStatus::Signalled { signal, .. } => Self::Signal(signal),
        }
    }
}

impl fmt::Display for ExitStatus {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Code(code) => write!(f, "exit code {code}"),
            Self::Signal(signal) => write!(f, "signal {signal}"),
        }
    }
}

/// Something the decision core must react to. Each comes with the time it happened
/// (`now_ns` of [`BrokerCore::handle`](super::BrokerCore::handle)).
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub enum Event {
    /// The broker is up: start the services whose start mode is `standby` or `always`.
    BrokerStarted,
    /// A client asks for an interface (not for a service). A client whose id is a service's
    /// name is never bound to that service.
    ClientRequest {
        /// Who asks.
        client: String,
        /// The interface it needs.
        interface: String,
    },
    /// A client went away: its bindings are dropped.
    ClientGone {
        /// Who went.
        client: String,
    },
    /// The process of a service was spawned (after a `Start` action).
    ProviderStarted {
        /// The service.
        service: String,
    },
    /// A service sent its first heartbeat: it is ready.
    ProviderReady {
        /// The service.
        service: String,
    },
    /// A service's heartbeat, with the health it declares.
    Heartbeat {
        /// The service.
        service: String,
        /// What it says of itself.
        health: Health,
    },
    /// A service's heartbeat thread found its event loop stuck in one step (busy past the
    /// heartbeat deadline, or asleep in a handler past it) and said so, once, before going
    /// silent: judged at once, not after a deadline of silence more.
    LoopStuck {
        /// The service.
        service: String,
        /// What its heartbeat thread saw.
        why: String,
    },
    /// A service's process ended.
    ProcessExited {
        /// The service.
        service: String,
        /// How it ended.
        status: ExitStatus,
    },
    /// Another host of the robot can no longer be reached (its session closed, or it was
    /// silent past the link deadline): its services can neither serve nor be started until
    /// it joins again, and those that ran are failed (their host stops them).
    HostLost {
        /// The host.
        host: String,
        /// What was seen.
        why: String,
    },
    /// Another host of the robot is reachable (again): its services may be chosen and
    /// started; those lost with it rejoin through the broker, never by themselves.
    HostJoined {
        /// The host.
        host: String,
    },
    /// A service's process could not be spawned (the program does not exist, is not
    /// executable, ...). Not retried: it would fail the same way.
    StartFailed {
        /// The service.
        service: String,
        /// What the system said.
        error: String,
    },
    /// A check of what a provider publishes on an interface failed (the broker's health
    /// module: rate, freshness, values, frozen). The robot file says whether the provider
    /// is then failed (its clients move, as for a stall) or degraded.
    DataCheckFailed {
        /// The service.
        service: String,
        /// The interface whose data failed the check.
        interface: String,
        /// The check's name (`rate`, `freshness`, `values`, `frozen`).
        check: String,
        /// What the check saw.
        reason: String,
    },
    /// What a service's process used of the CPU since the last measurement, from /proc, in
    /// thousandths of one core (1000: a whole core). The core smooths the measurements and
    /// counts them against the robot's CPU budget and in the cost of choosing the service;
    /// a service never measured counts with its declared cost. Recorded as every event is
    /// fed, so that replay decides the same.
    CpuMeasured {
        /// The service.
        service: String,
        /// Thousandths of one core.
        milli_cores: u32,
    },
    /// Time passed; the driver sends it when [`BrokerCore::next_deadline`](super::BrokerCore::next_deadline) is reached.
    TimePassed,
    /// The operator stops a service (it is not chosen again until restarted).
    StopService {
        /// The service.
        service: String,
    },
    /// The operator restarts a service (its failure history is forgotten).
    RestartService {
        /// The service.
        service: String,
    },
}

impl fmt::Display for Event {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::BrokerStarted => write!(f, "broker started"),
            Self::ClientRequest { client, interface } => {
                write!(f, "client {client} requests {interface}")
            }
            Self::ClientGone { client } => write!(f, "client {client} gone"),
            Self::ProviderStarted { service } => write!(f, "{service} process started"),
            Self::ProviderReady { service } => write!(f, "{service} ready"),
            Self::Heartbeat { service, health } => write!(f, "{service} heartbeat: {health}"),
            Self::LoopStuck { service, why } => write!(f, "{service} stalled: {why}"),
            Self::ProcessExited { service, status } => write!(f, "{service} exited with {status}"),
            Self::HostLost { host, why } => write!(f, "host {host} lost: {why}"),
            Self::HostJoined { host } => write!(f, "host {host} joined"),
            Self::StartFailed { service, error } => write!(f, "{service} could not start: {error}"),
            Self::DataCheckFailed {
                service,
                interface,
                check,
                reason,
            } => write!(
                f,
                "{service} failed its {check} check on {interface}: {reason}"
            ),
            Self::CpuMeasured {
                service,
                milli_cores,
            } => write!(
                f,
                "{service} used {} of a core",
                super::decision::fmt_cpu(*milli_cores)
            ),
            Self::TimePassed => write!(f, "time passed"),
            Self::StopService { service } => write!(f, "operator stops {service}"),
            Self::RestartService { service } => write!(f, "operator restarts {service}"),
        }
    }
}
