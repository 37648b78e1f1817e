//! The other hosts of a robot on more than one, as the robot host's broker drives them.
//!
//! The broker decides for the whole robot; a host's own supervisor carries out its starts
//! and stops and reports its exits. How the orders and reports travel (Zenoh, in
//! `lewis-bridge`) is not the broker's business: it sees this trait, so that the runtime
//! knows no network library, as only it knows iceoryx2.

use std::os::fd::BorrowedFd;
use std::time::Duration;

use super::ExitStatus;

/// What happened on the other hosts, in the order it was heard.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum HostEvent {
    /// A host can be reached (again).
    Joined {
        /// The host.
        host: String,
    },
    /// A host can no longer be reached.
    Lost {
        /// The host.
        host: String,
        /// What was seen (its session closed, silent past the link deadline).
        why: String,
    },
    /// A service's process on another host ended.
    Exited {
        /// The service.
        service: String,
        /// How it ended.
        status: ExitStatus,
    },
}

/// Why a service of another host was not started.
#[derive(Debug, Clone, PartialEq, Eq)]
pub enum RemoteStartError {
    /// The host answered that it could not (the spawn failed, no such service there).
    Refused(String),
    /// The host did not answer: the order or its answer was lost on the way.
    Unreachable(String),
}

/// The robot host's hold on the other hosts: orders to their supervisors, and what they
/// report.
pub trait RemoteHosts {
    /// Asks `host`'s supervisor to start `service`, waiting for its answer; returns the
    /// process id there.
    ///
    /// # Errors
    /// Why the service was not started: the host refused or could not spawn it, or the
    /// host did not answer (then it is taken as lost).
    fn start(&mut self, host: &str, service: &str) -> Result<u32, RemoteStartError>;

    /// Asks `host`'s supervisor to stop `service` (SIGTERM, then SIGKILL after the grace),
    /// without waiting: its exit comes back as [`HostEvent::Exited`].
    fn stop(&mut self, host: &str, service: &str);

    /// The next thing heard from the other hosts, if any.
    fn take_event(&mut self) -> Option<HostEvent>;

    /// How long `host` (one that joined) has been quiet, when it has missed several of
    /// its own beats: nothing heard from it, its beat and its services' heartbeats
    /// included. `None` while it is heard.
    fn quiet_for(&self, host: &str) -> Option<Duration>;

    /// The broker judged `host` lost itself (a service past its deadline, its whole host
    /// quiet): it is reported joined again once it is heard from.
    fn mark_lost(&mut self, host: &str);

    /// This host's clock minus `host`'s, plus the least one-way latency seen (the least,
    /// over the host's beats, of their arrival here minus the time they were sent with);
    /// `None` before a beat was heard.
    fn clock_offset_ns(&self, host: &str) -> Option<i64>;

    /// A descriptor that becomes readable when an event waits.
    fn wake_fd(&self) -> BorrowedFd<'_>;
}
