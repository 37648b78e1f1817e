//! The caller's side of a command that got no answer, recorded on `/lewis/calls`.
//!
//! The answering service logs every command it answers on `/lewis/commands/<service>`; a
//! call that times out, finds no provider, or whose provider dies or is replaced before
//! answering leaves nothing there. So every [`RawClient`](super::RawClient) keeps the calls
//! it has in flight (the frame, when, to whom) and publishes an
//! [`UnansweredCall`] when one ends without a reply, on its process's one publisher of the
//! channel ([`Ipc::shared_publisher`]), opened with the process's first client: a publisher
//! opened at the failure and gone with its process a moment later would leave the record
//! unread (the recorder maps a publisher's memory when it first reads from it).

use std::cell::RefCell;
use std::collections::BTreeMap;
use std::rc::Rc;
use std::sync::atomic::{AtomicU64, Ordering};
use std::time::Duration;

use lewis_interfaces::msg::{UnansweredCall, UnansweredCallStatus};

use crate::clock::LiveClock;
use crate::ipc::{CallId as IpcCallId, Ipc, Publisher};
use crate::names;
use lewis_service::wire;

/// Numbers the records of this process: its clients may each have a publisher, and a
/// reader orders them by the header's sequence.
static SEQ: AtomicU64 = AtomicU64::new(0);

/// A call sent and not yet answered.
#[derive(Debug)]
struct InFlight {
    frame: Vec<u8>,
    provider: String,
    timeout: Duration,
    sent_ns: i64,
}

/// The calls of one client in flight, and the publisher of its unanswered ones.
pub(super) struct UnansweredCalls {
    clock: LiveClock,
    in_flight: BTreeMap<IpcCallId, InFlight>,
    /// The process's publisher; `None` when the channel could not be opened (said once).
    publisher: Option<Rc<RefCell<Publisher>>>,
}

impl std::fmt::Debug for UnansweredCalls {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("UnansweredCalls")
            .field("in_flight", &self.in_flight)
            .field("recording", &self.publisher.is_some())
            .finish_non_exhaustive()
    }
}

/// What the record is about: the client and its interface.
pub(super) struct Caller<'a> {
    pub client: &'a str,
    pub interface: &'a str,
}

impl UnansweredCalls {
    /// The record of `client`'s calls of `interface`, on `ipc`'s shared publisher.
    pub(super) fn new(ipc: &Ipc, client: &str, interface: &str) -> Self {
        let publisher = ipc
            .shared_publisher(names::CALLS_CHANNEL, &names::calls_config())
            .map_err(|e| {
                tracing::warn!(
                    client,
                    "cannot open {}: unanswered calls of {interface} are not recorded: {e}",
                    names::CALLS_CHANNEL
                );
            })
            .ok();
        Self {
            clock: LiveClock::new(),
            in_flight: BTreeMap::new(),
            publisher,
        }
    }

    /// A call was sent to `provider`.
    pub(super) fn sent(
        &mut self,
        call: IpcCallId,
        frame: &[u8],
        provider: &str,
        timeout: Duration,
    ) {
        self.in_flight.insert(
            call,
            InFlight {
                frame: frame.to_vec(),
                provider: provider.to_owned(),
                timeout,
                sent_ns: self.clock.now_ns(),
            },
        );
    }

    /// A call ended: answered (`None`), or not, and why.
    pub(super) fn ended(
        &mut self,
        caller: &Caller<'_>,
        call: IpcCallId,
        unanswered: Option<(UnansweredCallStatus, String)>,
    ) {
        let Some(call) = self.in_flight.remove(&call) else {
            return;
        };
        if let Some((status, error)) = unanswered {
            self.record(caller, &call, status, &error);
        }
    }

    /// The client left its provider: no call in flight will be answered.
    pub(super) fn provider_gone(&mut self, caller: &Caller<'_>) {
        for call in std::mem::take(&mut self.in_flight).into_values() {
            self.record(caller, &call, UnansweredCallStatus::ProviderGone, "");
        }
    }

    /// A call that could not be sent at all.
    pub(super) fn not_sent(
        &mut self,
        caller: &Caller<'_>,
        frame: &[u8],
        provider: Option<&str>,
        timeout: Duration,
        status: UnansweredCallStatus,
        error: &str,
    ) {
        let call = InFlight {
            frame: frame.to_vec(),
            provider: provider.unwrap_or_default().to_owned(),
            timeout,
            sent_ns: self.clock.now_ns(),
        };
        self.record(caller, &call, status, error);
    }

    fn record(
        &mut self,
        caller: &Caller<'_>,
        call: &InFlight,
        status: UnansweredCallStatus,
        error: &str,
    ) {
        let (command, request) = wire::read_request(&call.frame).unwrap_or(("", &[]));
        if call.provider.is_empty() {
            tracing::debug!(
                client = caller.client,
                "{}.{command} got no answer: {status}",
                caller.interface
            );
        } else {
            tracing::debug!(
                client = caller.client,
                "{}.{command} to {} got no answer: {status}",
                caller.interface,
                call.provider
            );
        }
        let mut message = UnansweredCall {
            client: caller.client.to_owned(),
            interface: caller.interface.to_owned(),
            command: command.to_owned(),
            request: request.to_vec(),
            provider: call.provider.clone(),
            status: status.into(),
            error: error.to_owned(),
            timeout_ns: i64::try_from(call.timeout.as_nanos()).unwrap_or(i64::MAX),
            sent_ns: call.sent_ns,
            ..UnansweredCall::default()
        };
        let Some(publisher) = &self.publisher else {
            return;
        };
        let seq = SEQ.fetch_add(1, Ordering::Relaxed) + 1;
        let now_ns = self.clock.now_ns();
        if let Err(e) =
            publisher
                .borrow_mut()
                .publish_stamped(&mut message, caller.client, seq, now_ns)
        {
            tracing::warn!(
                client = caller.client,
                "cannot record an unanswered call: {e}"
            );
        }
    }
}
