//! The broker's status as a typed reply (`status` on `/lewis/broker/cmd`), and the text
//! `lewis status` prints from it. Tools read the reply's fields (a service's pid, its
//! state); nothing parses the text.

use std::fmt;

use lewis_interfaces::msg::{BindingReport, BrokerStatusReply, ServiceReport, ServiceReportState};

use super::{ServiceState, Snapshot};
use crate::live::{health_fields, health_from_fields};

/// The status reply for `snapshot` of robot `robot` in `namespace` at `now_ns` (the
/// broker's clock); `pid` gives the process of a service that runs one.
#[must_use]
pub fn status_reply(
    robot: &str,
    namespace: &str,
    snapshot: &Snapshot,
    now_ns: i64,
    pid: impl Fn(&str) -> Option<i32>,
) -> BrokerStatusReply {
    let services: Vec<ServiceReport> = snapshot
        .services
        .iter()
        .map(|s| {
            let (health, health_reason) = health_fields(&s.health);
            ServiceReport {
                name: s.name.clone(),
                state: state_word(&s.state).to_string(),
                state_detail: s.detail_at(now_ns),
                health: health.to_string(),
                health_reason: health_reason.to_owned(),
                restarts: s.restarts,
                clients: u32::try_from(s.clients).unwrap_or(u32::MAX),
                last_failure: s.last_failure.clone().unwrap_or_default(),
                pid: pid(&s.name).unwrap_or(0),
            }
        })
        .collect();
    let bindings: Vec<BindingReport> = snapshot
        .bindings
        .iter()
        .map(|b| BindingReport {
            client: b.client.clone(),
            interface: b.interface.clone(),
            service: b.service.clone().unwrap_or_default(),
        })
        .collect();
    let count = |n: usize| u32::try_from(n).unwrap_or(u32::MAX);
    BrokerStatusReply {
        robot: robot.to_owned(),
        namespace: namespace.to_owned(),
        service_count: count(services.len()),
        services,
        binding_count: count(bindings.len()),
        bindings,
        help_count: count(snapshot.help_asked.len()),
        help_asked: snapshot.help_asked.clone(),
        ..BrokerStatusReply::default()
    }
}

/// The word of a service state in [`ServiceReport::state`].
#[must_use]
pub fn state_word(state: &ServiceState) -> ServiceReportState {
    match state {
        ServiceState::Idle => ServiceReportState::Idle,
        ServiceState::Starting { .. } => ServiceReportState::Starting,
        ServiceState::Ready { .. } => ServiceReportState::Ready,
        ServiceState::Restarting { .. } => ServiceReportState::Restarting,
        ServiceState::Stopping { .. } => ServiceReportState::Stopping,
        ServiceState::Stopped => ServiceReportState::Stopped,
        ServiceState::Failed { .. } => ServiceReportState::Failed,
    }
}

/// The process of `service` in a status reply, when it runs one.
#[must_use]
pub fn pid_of(reply: &BrokerStatusReply, service: &str) -> Option<i32> {
    reply
        .services
        .iter()
        .find(|s| s.name == service)
        .map(|s| s.pid)
        .filter(|pid| *pid > 0)
}

/// A status reply as `lewis status` prints it: one line per service, binding, interface
/// help was asked for, and process.
#[derive(Debug, Clone, Copy)]
pub struct StatusText<'a>(pub &'a BrokerStatusReply);

impl fmt::Display for StatusText<'_> {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        let reply = self.0;
        writeln!(f, "robot {} in namespace {}", reply.robot, reply.namespace)?;
        for s in &reply.services {
            let health = health_from_fields(&s.health, &s.health_reason);
            write!(
                f,
                "service {}: {}, health {health}, {} restarts, {} clients",
                s.name, s.state_detail, s.restarts, s.clients
            )?;
            if !s.last_failure.is_empty() {
                write!(f, ", last failure: {}", s.last_failure)?;
            }
            writeln!(f)?;
        }
        for b in &reply.bindings {
            if b.service.is_empty() {
                writeln!(f, "client {} {} -> (waiting)", b.client, b.interface)?;
            } else {
                writeln!(f, "client {} {} -> {}", b.client, b.interface, b.service)?;
            }
        }
        for interface in &reply.help_asked {
            writeln!(f, "help asked for {interface}")?;
        }
        for s in reply.services.iter().filter(|s| s.pid > 0) {
            writeln!(f, "process {}: pid {}", s.name, s.pid)?;
        }
        Ok(())
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::broker::{Binding, ServiceStatus};
    use lewis_service::Health;

    fn snapshot() -> Snapshot {
        Snapshot {
            services: vec![
                ServiceStatus {
                    name: "laser".into(),
                    state: ServiceState::Failed { retry_at_ns: None },
                    health: Health::OutOfService("no scans".into()),
                    restarts: 3,
                    last_failure: Some("crashed 3 times".into()),
                    clients: 0,
                    probation_until_ns: None,
                },
                ServiceStatus {
                    name: "sonar".into(),
                    state: ServiceState::Stopped,
                    health: Health::Ok,
                    restarts: 0,
                    last_failure: None,
                    clients: 1,
                    probation_until_ns: None,
                },
            ],
            bindings: vec![
                Binding {
                    client: "avoider".into(),
                    interface: "RangeFinder".into(),
                    service: Some("sonar".into()),
                },
                Binding {
                    client: "goal".into(),
                    interface: "Mover".into(),
                    service: None,
                },
            ],
            help_asked: vec!["Blobs".into()],
        }
    }

    #[test]
    fn the_reply_carries_states_and_pids_as_fields() {
        let reply = status_reply("b21r", "test", &snapshot(), 0, |name| {
            (name == "sonar").then_some(4242)
        });
        assert_eq!(pid_of(&reply, "sonar"), Some(4242));
        assert_eq!(pid_of(&reply, "laser"), None);
        assert_eq!(pid_of(&reply, "camera"), None);
        assert_eq!(reply.services[0].state, ServiceReportState::Failed);
        assert_eq!(
            reply.services[0].health,
            lewis_interfaces::msg::HealthState::OutOfService
        );
        assert_eq!(reply.service_count, 2);
        assert_eq!(reply.binding_count, 2);
    }

    #[test]
    fn the_text_for_people_says_what_the_snapshot_says() {
        let reply = status_reply("b21r", "test", &snapshot(), 0, |name| {
            (name == "sonar").then_some(4242)
        });
        // The reply survives the wire.
        let bytes = lewis_interfaces::cdr::to_vec(&reply);
        let reply: BrokerStatusReply =
            lewis_interfaces::cdr::from_bytes(&bytes).unwrap_or_else(|e| panic!("{e}"));
        assert_eq!(
            StatusText(&reply).to_string(),
            "robot b21r in namespace test\n\
             service laser: failed, health out of service (no scans), 3 restarts, 0 clients, \
             last failure: crashed 3 times\n\
             service sonar: stopped, health ok, 0 restarts, 1 clients\n\
             client avoider RangeFinder -> sonar\n\
             client goal Mover -> (waiting)\n\
             help asked for Blobs\n\
             process sonar: pid 4242\n"
        );
    }
}
