//! What the broker says, for the end-to-end tests: its decisions on `/lewis/broker` as they
//! are published, and its status report, re-read only when something happened.

#![allow(clippy::expect_used)]

use std::rc::Rc;
use std::time::Instant;

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Broker, BrokerStatus, BrokerStatusReply};
use lewis_runtime::ipc::{Ipc, Namespace, Subscriber, WaitSet, Waitable, WakeMode, Woken};
use lewis_runtime::names;

use crate::WATCHDOG;

/// The broker's decisions, received from `/lewis/broker` from the moment this was made
/// (the channel keeps no history: make it before the action whose decisions are awaited).
pub struct Decisions {
    _ipc: Rc<Ipc>,
    subscriber: Subscriber,
    waits: WaitSet,
    /// Every decision received so far, in order.
    pub seen: Vec<Broker>,
    /// Where [`Decisions::wait_for`] looks next.
    next: usize,
}

impl Decisions {
    /// Subscribes to the decisions of the broker of `namespace`.
    ///
    /// # Panics
    /// When the channel cannot be opened.
    #[must_use]
    pub fn subscribe(namespace: &Namespace) -> Self {
        let ipc =
            Rc::new(Ipc::open(namespace, "test-decisions").expect("the test's IPC node opens"));
        let subscriber = ipc
            .subscriber(names::BROKER_CHANNEL, &names::broker_config())
            .expect("the broker's channel opens");
        Self {
            _ipc: ipc,
            subscriber,
            waits: WaitSet::new(WakeMode::Event),
            seen: Vec::new(),
            next: 0,
        }
    }

    /// Waits (watchdog) for the next decision, after the one returned last, that `accept`
    /// accepts, and returns it. Decisions in between are kept in [`Decisions::seen`].
    ///
    /// # Panics
    /// When none comes, listing every decision seen.
    pub fn wait_for(&mut self, what: &str, accept: impl Fn(&Broker) -> bool) -> Broker {
        let deadline = Instant::now() + WATCHDOG;
        loop {
            if let Some(offset) = self.seen[self.next..].iter().position(&accept) {
                let index = self.next + offset;
                self.next = index + 1;
                return self.seen[index].clone();
            }
            self.next = self.seen.len();
            let woken = self
                .waits
                .wait(&[&self.subscriber], Some(deadline))
                .expect("waiting works");
            assert!(
                woken != Woken::DeadlineReached,
                "the broker never decided {what}; it decided:\n{}",
                self.describe()
            );
            self.take();
        }
    }

    /// Takes the decisions published for `span` from now, as they come (a window of
    /// observation: nothing is awaited).
    ///
    /// # Panics
    /// When waiting fails.
    pub fn watch_for(&mut self, span: std::time::Duration) {
        let until = Instant::now() + span;
        while Instant::now() < until {
            self.waits
                .wait(&[&self.subscriber], Some(until))
                .expect("waiting works");
            self.take();
        }
    }

    /// Takes the decisions published so far, without waiting.
    pub fn take(&mut self) {
        while let Some(sample) = self.subscriber.receive().expect("receiving works") {
            if let Ok(decision) = cdr::from_bytes::<Broker>(sample.bytes()) {
                self.seen.push(decision);
            }
        }
    }

    /// Every decision seen, one a line: `ACTION CLIENT INTERFACE SERVICE FROM->TO: REASON`.
    #[must_use]
    pub fn describe(&self) -> String {
        self.seen
            .iter()
            .map(|d| {
                format!(
                    "{} client={} interface={} service={} {}->{}: {}",
                    d.action,
                    d.client,
                    d.interface,
                    d.service,
                    d.from_service,
                    d.to_service,
                    d.reason
                )
            })
            .collect::<Vec<_>>()
            .join("\n")
    }
}

/// The status reply of the broker of `ipc`'s namespace.
///
/// # Panics
/// When the broker does not answer.
#[must_use]
pub fn status_reply(ipc: &Ipc) -> BrokerStatusReply {
    let mut broker = ipc
        .command_client(names::BROKER_COMMAND, &names::broker_command_config())
        .expect("the broker's command channel opens");
    lewis_runtime::client::call_blocking(&mut broker, &BrokerStatus::default(), WATCHDOG)
        .expect("the broker answers")
}

/// The status report of the broker of `ipc`'s namespace (what `lewis status` prints).
///
/// # Panics
/// When the broker does not answer.
#[must_use]
pub fn status(ipc: &Ipc) -> String {
    lewis_runtime::broker::status::StatusText(&status_reply(ipc)).to_string()
}

/// Asks the broker of `namespace` for its status report until `accept` accepts it, and
/// returns it. Between two reports it waits for something that can change the report: a
/// decision on `/lewis/broker` or a heartbeat of one of the robot's services (a change of
/// declared health is no decision).
///
/// # Panics
/// When no report is accepted within the watchdog.
pub fn wait_status(namespace: &Namespace, what: &str, accept: impl Fn(&str) -> bool) -> String {
    let ipc = Ipc::open(namespace, "test-status").expect("the test's IPC node opens");
    let mut sources = vec![
        ipc.subscriber(names::BROKER_CHANNEL, &names::broker_config())
            .expect("the broker's channel opens"),
    ];
    let mut report = status(&ipc);
    for service in report.lines().filter_map(|l| {
        l.strip_prefix("service ")?
            .split_once(':')
            .map(|(name, _)| name)
    }) {
        sources.push(
            ipc.subscriber(&names::health_channel(service), &names::health_config())
                .expect("a health channel opens"),
        );
    }
    let waits = WaitSet::new(WakeMode::Event);
    let deadline = Instant::now() + WATCHDOG;
    loop {
        if accept(&report) {
            return report;
        }
        let waitables: Vec<&dyn Waitable> = sources.iter().map(|s| s as &dyn Waitable).collect();
        let woken = waits
            .wait(&waitables, Some(deadline))
            .expect("waiting works");
        assert!(
            woken != Woken::DeadlineReached,
            "the broker never reported {what}; last report:\n{report}"
        );
        for source in &mut sources {
            while source.receive().expect("receiving works").is_some() {}
        }
        report = status(&ipc);
    }
}
