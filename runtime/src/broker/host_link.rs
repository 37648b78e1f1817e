//! What the robot host's broker hears of the other hosts, said on `/lewis/hosts`
//! ([`names::HOSTS_CHANNEL`]): each host joined or lost as the core is told it, and about
//! once a second each joined host's clock offset. The recorder keeps it, so that a replay
//! loses and joins the hosts when the live broker did, and a person can read how far the
//! hosts' clocks were apart.

use std::collections::BTreeSet;

use lewis_interfaces::msg::{HostLink, HostLinkEvent};

use super::Event;
use super::remote::RemoteHosts;
use crate::ipc::{Ipc, IpcError, Publisher};
use crate::names;

/// The broker's word on the other hosts, for a robot on more than one.
pub(super) struct HostLinks {
    out: Publisher,
    /// Records published so far (the header's sequence).
    seq: u64,
    /// The hosts joined and not lost since.
    joined: BTreeSet<String>,
}

impl HostLinks {
    /// Opens `/lewis/hosts`.
    pub(super) fn open(ipc: &Ipc) -> Result<Self, IpcError> {
        Ok(Self {
            out: ipc.publisher(names::HOSTS_CHANNEL, &names::hosts_config())?,
            seq: 0,
            joined: BTreeSet::new(),
        })
    }

    /// Says `event` at `at_ns` when it is a host's joining or loss (other events are not
    /// about hosts).
    pub(super) fn on_event(&mut self, event: &Event, remote: Option<&dyn RemoteHosts>, at_ns: i64) {
        let (host, kind, reason) = match event {
            Event::HostJoined { host } => {
                self.joined.insert(host.clone());
                (host, HostLinkEvent::Joined, "")
            }
            Event::HostLost { host, why } => {
                self.joined.remove(host);
                (host, HostLinkEvent::Lost, why.as_str())
            }
            _ => return,
        };
        let offset = remote.and_then(|r| r.clock_offset_ns(host));
        self.say(host, kind, reason, offset, at_ns);
    }

    /// Says of each joined host that it is heard, with its clock offset as measured so far.
    pub(super) fn heard(&mut self, remote: &dyn RemoteHosts, at_ns: i64) {
        let joined: Vec<String> = self.joined.iter().cloned().collect();
        for host in joined {
            let offset = remote.clock_offset_ns(&host);
            self.say(&host, HostLinkEvent::Heard, "", offset, at_ns);
        }
    }

    fn say(
        &mut self,
        host: &str,
        event: HostLinkEvent,
        reason: &str,
        clock_offset_ns: Option<i64>,
        at_ns: i64,
    ) {
        self.seq += 1;
        let mut message = HostLink {
            host: host.to_owned(),
            event: event.into(),
            reason: reason.to_owned(),
            clock_measured: clock_offset_ns.is_some(),
            clock_offset_ns: clock_offset_ns.unwrap_or(0),
            ..HostLink::default()
        };
        if let Err(e) = self
            .out
            .publish_stamped(&mut message, names::BROKER_NODE, self.seq, at_ns)
        {
            tracing::debug!("cannot publish what was heard of host {host}: {e}");
        }
    }
}
