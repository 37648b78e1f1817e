//! What `lewis status` shows: every service's state, health and restarts, and every binding.

use std::fmt;

use serde::{Deserialize, Serialize};

use super::BrokerCore;
use super::decision::{fmt_span, fmt_time};
use super::service::{AfterStop, ServiceState};
use lewis_service::Health;

/// The broker's state at one moment.
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Snapshot {
    /// Every service of the robot, by name.
    pub services: Vec<ServiceStatus>,
    /// Every client's interface and its provider, by client then interface.
    pub bindings: Vec<Binding>,
    /// Interfaces for which help was asked and no provider came back since.
    pub help_asked: Vec<String>,
}

/// One service in a [`Snapshot`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct ServiceStatus {
    /// Its name.
    pub name: String,
    /// Where it is in its life.
    pub state: ServiceState,
    /// What it last declared.
    pub health: Health,
    /// How many times the broker restarted it after a crash.
    pub restarts: u32,
    /// Why it last failed for good, if it ever did.
    pub last_failure: Option<String>,
    /// How many client bindings it has.
    pub clients: usize,
    /// When a retried service's probation ends, while it is on trial (clients fail back
    /// to it only after).
    pub probation_until_ns: Option<i64>,
}

/// One client's interface in a [`Snapshot`].
#[derive(Debug, Clone, PartialEq, Eq, Serialize, Deserialize)]
pub struct Binding {
    /// The client.
    pub client: String,
    /// The interface it asked for.
    pub interface: String,
    /// Its provider, or `None` while it waits for one.
    pub service: Option<String>,
}

impl BrokerCore {
    /// The state of every service and binding, for `lewis status`.
    #[must_use]
    pub fn snapshot(&self) -> Snapshot {
        let bindings: Vec<Binding> = self
            .clients
            .iter()
            .flat_map(|(client, b)| {
                b.iter().map(move |(interface, service)| Binding {
                    client: client.clone(),
                    interface: interface.clone(),
                    service: service.clone(),
                })
            })
            .collect();
        let services = self
            .services
            .iter()
            .map(|(name, e)| ServiceStatus {
                name: name.clone(),
                state: e.state,
                health: e.health.clone(),
                restarts: e.restarts,
                last_failure: e.last_failure.clone(),
                clients: bindings
                    .iter()
                    .filter(|b| b.service.as_ref() == Some(name))
                    .count(),
                probation_until_ns: e.probation_until_ns(),
            })
            .collect();
        Snapshot {
            services,
            bindings,
            help_asked: self.help_asked.iter().cloned().collect(),
        }
    }
}

impl ServiceStatus {
    /// Its state in words, with its probation while it is on trial, its times as the core
    /// keeps them (a test's virtual clock).
    #[must_use]
    pub fn detail(&self) -> String {
        match self.probation_until_ns {
            Some(end) => format!("{}, on probation until {}", self.state, fmt_time(end)),
            None => self.state.to_string(),
        }
    }

    /// Its state in words for a person at `now_ns` (what `lewis status` prints): times as
    /// how long ago or how soon, since a live clock reads nanoseconds since 1970.
    #[must_use]
    pub fn detail_at(&self, now_ns: i64) -> String {
        let ago = |at: i64| fmt_span(now_ns.saturating_sub(at));
        let until = |at: i64| fmt_span(at.saturating_sub(now_ns));
        let mut text = match self.state {
            ServiceState::Starting { since_ns } => format!("starting for {}", ago(since_ns)),
            ServiceState::Ready { last_heartbeat_ns } => {
                format!("ready, last heartbeat {} ago", ago(last_heartbeat_ns))
            }
            ServiceState::Restarting { at_ns, attempt } => {
                format!("restarting in {} (attempt {attempt})", until(at_ns))
            }
            ServiceState::Failed {
                retry_at_ns: Some(at),
            } => format!("failed, retry in {}", until(at)),
            state => state.to_string(),
        };
        if let Some(end) = self.probation_until_ns {
            text.push_str(&format!(", on probation for {} more", until(end)));
        }
        text
    }
}

impl fmt::Display for ServiceState {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        match self {
            Self::Idle => write!(f, "idle"),
            Self::Starting { since_ns } => write!(f, "starting since {}", fmt_time(*since_ns)),
            Self::Ready { last_heartbeat_ns } => {
                write!(f, "ready, last heartbeat {}", fmt_time(*last_heartbeat_ns))
            }
            Self::Restarting { at_ns, attempt } => {
                write!(f, "restarting at {} (attempt {attempt})", fmt_time(*at_ns))
            }
            Self::Stopping { then } => match then {
                AfterStop::Stopped => write!(f, "stopping"),
                AfterStop::Restart => write!(f, "stopping to restart"),
                AfterStop::Failed { .. } => write!(f, "stopping, failed"),
            },
            Self::Stopped => write!(f, "stopped"),
            Self::Failed { retry_at_ns: None } => write!(f, "failed"),
            Self::Failed {
                retry_at_ns: Some(at),
            } => write!(f, "failed, retry at {}", fmt_time(*at)),
        }
    }
}

impl fmt::Display for Snapshot {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        for s in &self.services {
            write!(f, "service {}: {}", s.name, s.detail())?;
            write!(
                f,
                ", health {}, {} restarts, {} clients",
                s.health, s.restarts, s.clients
            )?;
            if let Some(why) = &s.last_failure {
                write!(f, ", last failure: {why}")?;
            }
            writeln!(f)?;
        }
        for b in &self.bindings {
            match &b.service {
                Some(service) => writeln!(f, "client {} {} -> {service}", b.client, b.interface)?,
                None => writeln!(f, "client {} {} -> (waiting)", b.client, b.interface)?,
            }
        }
        for interface in &self.help_asked {
            writeln!(f, "help asked for {interface}")?;
        }
        Ok(())
    }
}
