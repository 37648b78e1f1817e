//! Typed clients that follow rebinding: [`Client<RangeFinder>`](Client) asks the broker for
//! an interface, not a device, subscribes to the provider it is bound to, and when the broker
//! moves it to another provider (published on `/lewis/broker`) it switches its subscription
//! by itself and says so in one log line. The application sees only the provider's name
//! change in the headers of the samples.
//!
//! A sample is decoded into an owned message ([`Client::recv_timeout`]) or read in place in
//! shared memory ([`Client::recv_view_timeout`]: the message's view, nothing copied), which
//! is what a consumer of camera frames or large scans wants.
//!
//! [`RawClient`] is the untyped core (interface given by name), used by the live harness
//! for a service's required interfaces; [`Client`] wraps it for applications.

mod unanswered;

use std::marker::PhantomData;
use std::rc::Rc;
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{
    Broker, BrokerAction, BrokerRelease, BrokerRequest, BrokerRequestReply,
    BrokerRequestReplyStatus, UnansweredCallStatus,
};
use lewis_interfaces::{Command, Interface};

use crate::ipc::{
    CallError, CallOutcome, CommandClient, IpcError, ReceiveError, Received, Subscriber, WaitError,
    WaitSet, Waitable, WakeMode, Woken,
};
use crate::ipc::{CallId as IpcCallId, Ipc, SPINS_PER_CLOCK_READ};
use crate::names;
use lewis_service::wire;
use unanswered::{Caller, UnansweredCalls};

/// While the broker cannot be reached, a client asks again this often.
const RETRY_REQUEST: Duration = Duration::from_millis(50);

/// Why a client failed.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ClientError {
    /// A channel could not be opened.
    #[error(transparent)]
    Ipc(#[from] IpcError),
    /// A sample could not be received.
    #[error(transparent)]
    Receive(#[from] ReceiveError),
    /// Waiting failed.
    #[error(transparent)]
    Wait(#[from] WaitError),
    /// No service of the robot provides the interface.
    #[error("the broker says no service of this robot provides {interface}")]
    Rejected {
        /// The interface.
        interface: String,
    },
    /// A sample does not decode as the interface's publication.
    #[error("sample of {interface} from {provider} does not decode: {reason}")]
    Decode {
        /// The interface.
        interface: String,
        /// Its provider.
        provider: String,
        /// What is wrong.
        reason: String,
    },
    /// The client has no provider now (waiting for the broker).
    #[error("{interface} has no provider now: the broker has not bound {client} yet")]
    Unbound {
        /// The client.
        client: String,
        /// The interface.
        interface: String,
    },
    /// A command failed in IPC (no server, timeout, ...).
    #[error(transparent)]
    Call(#[from] CallError),
    /// The provider refused the command.
    #[error("{interface}.{command} refused by {provider}: {reason}")]
    Refused {
        /// The interface.
        interface: String,
        /// The command.
        command: String,
        /// The provider.
        provider: String,
        /// Its reason.
        reason: String,
    },
    /// A reply is not what was expected.
    #[error("bad reply to {command}: {reason}")]
    BadReply {
        /// The command.
        command: String,
        /// What is wrong.
        reason: String,
    },
}

/// A change of provider seen by a client.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct BindingChange {
    /// The provider it had.
    pub from: Option<String>,
    /// The provider it has now.
    pub to: Option<String>,
    /// The broker's reason.
    pub reason: String,
}

/// The untyped client of one interface: follows the broker's binding of `(client,
/// interface)` and holds the subscription and command channel of the current provider.
#[derive(Debug)]
pub struct RawClient {
    ipc: Rc<Ipc>,
    client: String,
    interface: String,
    decisions: Subscriber,
    broker: CommandClient,
    request: Option<IpcCallId>,
    retry_at: Option<Instant>,
    decisions_lost: u64,
    provider: Option<String>,
    data: Option<Subscriber>,
    data_channel: String,
    commands: Option<CommandClient>,
    /// Calls in flight, and the record of those never answered (`/lewis/calls`).
    unanswered: UnansweredCalls,
    released: bool,
}

impl RawClient {
    /// Asks the broker for `interface` on behalf of `client`. Does not wait: the binding
    /// arrives through [`RawClient::process`].
    ///
    /// # Errors
    /// When the broker's channels cannot be opened.
    pub fn new(ipc: &Rc<Ipc>, client: &str, interface: &str) -> Result<Self, ClientError> {
        // Decisions first, so that the bind that answers our request cannot be missed.
        let decisions = ipc.subscriber(names::BROKER_CHANNEL, &names::broker_config())?;
        let broker = ipc.command_client(names::BROKER_COMMAND, &names::broker_command_config())?;
        let mut raw = Self {
            ipc: Rc::clone(ipc),
            client: client.to_owned(),
            interface: interface.to_owned(),
            decisions,
            broker,
            request: None,
            retry_at: None,
            decisions_lost: 0,
            provider: None,
            data: None,
            data_channel: String::new(),
            commands: None,
            unanswered: UnansweredCalls::new(ipc, client, interface),
            released: false,
        };
        raw.send_request();
        Ok(raw)
    }

    /// The client's name.
    #[must_use]
    pub fn client(&self) -> &str {
        &self.client
    }

    /// The interface.
    #[must_use]
    pub fn interface(&self) -> &str {
        &self.interface
    }

    /// The current provider.
    #[must_use]
    pub fn provider(&self) -> Option<&str> {
        self.provider.as_deref()
    }

    /// The data channel of the current provider (empty while unbound).
    #[must_use]
    pub fn data_channel(&self) -> &str {
        &self.data_channel
    }

    /// When the client must be processed again even if nothing arrives (a retry of its
    /// request while the broker is unreachable).
    #[must_use]
    pub fn deadline(&self) -> Option<Instant> {
        self.retry_at
    }

    /// Whether [`RawClient::process`] has something to take in: a decision of the broker,
    /// the answer to a request, or a request to send again. No system call: a busy-polling
    /// reader checks it between polls of the data.
    #[must_use]
    pub fn has_news(&self) -> bool {
        self.decisions.has_data()
            || self.retry_at.is_some()
            || (self.request.is_some() && self.broker.has_outcome())
    }

    /// What to wait on: the broker's decisions, the answer to a pending request, the data
    /// and the replies of the current provider.
    #[must_use]
    pub fn waitables(&self) -> Vec<&dyn Waitable> {
        let mut out: Vec<&dyn Waitable> = vec![&self.decisions];
        if self.request.is_some() {
            out.push(&self.broker);
        }
        if let Some(data) = &self.data {
            out.push(data);
        }
        if let Some(commands) = &self.commands
            && commands.pending() > 0
        {
            out.push(commands);
        }
        out
    }

    /// Takes in the broker's answers and decisions and follows them; returns the change of
    /// provider, if any.
    ///
    /// # Errors
    /// When the broker rejects the request, or a subscription cannot be opened.
    pub fn process(&mut self) -> Result<Option<BindingChange>, ClientError> {
        // The provider before the first switch, kept only when there is one: this runs on
        // every receive, and almost never switches.
        let mut before: Option<Option<String>> = None;
        let mut reason = String::new();
        if self.retry_at.is_some_and(|at| Instant::now() >= at) {
            self.send_request();
        }
        if self.request.is_some() {
            while let Some(outcome) = self.broker.take_outcome() {
                if let Some(r) = self.on_request_outcome(outcome, &mut before)? {
                    reason = r;
                }
            }
        }
        while let Some(sample) = self.decisions.receive()? {
            let Ok(decision) = cdr::from_bytes::<Broker>(sample.bytes()) else {
                continue;
            };
            if decision.client != self.client || decision.interface != self.interface {
                continue;
            }
            match BrokerAction::parse(&decision.action) {
                Some(BrokerAction::Bind) => self.switch_to(Some(&decision.service), &mut before)?,
                Some(BrokerAction::Rebind) => {
                    self.switch_to(Some(&decision.to_service), &mut before)?;
                }
                Some(BrokerAction::Unbind) => self.switch_to(None, &mut before)?,
                Some(BrokerAction::Reject) => {
                    return Err(ClientError::Rejected {
                        interface: self.interface.clone(),
                    });
                }
                _ => continue,
            }
            reason = decision.reason;
        }
        // A gap in the decisions may have hidden a rebind: ask again, the broker answers
        // with the current binding.
        if self.decisions.lost() != self.decisions_lost {
            self.decisions_lost = self.decisions.lost();
            if self.request.is_none() {
                self.send_request();
            }
        }
        let Some(before) = before.filter(|b| *b != self.provider) else {
            return Ok(None);
        };
        let change = BindingChange {
            from: before,
            to: self.provider.clone(),
            reason,
        };
        match (&change.from, &change.to) {
            (Some(from), Some(to)) => tracing::info!(
                client = self.client,
                "{} moved from {from} to {to}: {}",
                self.interface,
                change.reason
            ),
            (None, Some(to)) => {
                tracing::debug!(client = self.client, "{} bound to {to}", self.interface);
            }
            (Some(from), None) => tracing::warn!(
                client = self.client,
                "{} lost its provider {from}: {}",
                self.interface,
                change.reason
            ),
            (None, None) => {}
        }
        Ok(Some(change))
    }

    /// The oldest unread sample of the current provider.
    ///
    /// # Errors
    /// When receiving fails.
    pub fn receive(&mut self) -> Result<Option<Received>, ClientError> {
        match &mut self.data {
            Some(data) => Ok(data.receive()?),
            None => Ok(None),
        }
    }

    /// The newest unread sample of the current provider (older ones are skipped).
    ///
    /// # Errors
    /// When receiving fails.
    pub fn latest(&mut self) -> Result<Option<Received>, ClientError> {
        match &mut self.data {
            Some(data) => Ok(data.latest()?),
            None => Ok(None),
        }
    }

    /// Sends a command frame ([`wire`]) to the current provider. A call that is never
    /// answered (not sent, timed out, its provider gone) is recorded on `/lewis/calls`.
    ///
    /// # Errors
    /// When unbound, or when the call cannot be sent.
    pub fn call(&mut self, frame: &[u8], timeout: Duration) -> Result<IpcCallId, ClientError> {
        let sent = self.send(frame, timeout);
        let caller = Caller {
            client: &self.client,
            interface: &self.interface,
        };
        let provider = self.provider.as_deref();
        match &sent {
            Ok(call) => self
                .unanswered
                .sent(*call, frame, provider.unwrap_or_default(), timeout),
            Err(e) => {
                let status = match e {
                    ClientError::Unbound { .. } => UnansweredCallStatus::NoProvider,
                    ClientError::Call(CallError::NoServer { .. }) => {
                        UnansweredCallStatus::ProviderGone
                    }
                    _ => UnansweredCallStatus::Failed,
                };
                self.unanswered
                    .not_sent(&caller, frame, provider, timeout, status, &e.to_string());
            }
        }
        sent
    }

    fn send(&mut self, frame: &[u8], timeout: Duration) -> Result<IpcCallId, ClientError> {
        let Some(provider) = &self.provider else {
            return Err(ClientError::Unbound {
                client: self.client.clone(),
                interface: self.interface.clone(),
            });
        };
        // Opened at the first call, not at binding: most clients never call, and a
        // failover reaches the data first.
        if self.commands.is_none() {
            let channel = names::command_channel(provider, &self.interface);
            self.commands = Some(
                self.ipc
                    .command_client(&channel, &names::command_config())?,
            );
        }
        let commands = self.commands.as_mut().ok_or_else(|| ClientError::Unbound {
            client: self.client.clone(),
            interface: self.interface.clone(),
        })?;
        Ok(commands.call(frame, timeout)?)
    }

    /// The outcome of a finished call, if one is ready.
    pub fn take_call_outcome(&mut self) -> Option<CallOutcome> {
        let outcome = self.commands.as_mut()?.take_outcome()?;
        let unanswered = match &outcome.result {
            Ok(_) => None,
            Err(CallError::Timeout { .. }) => Some((UnansweredCallStatus::TimedOut, String::new())),
            Err(CallError::NoServer { .. }) => {
                Some((UnansweredCallStatus::ProviderGone, String::new()))
            }
            Err(e) => Some((UnansweredCallStatus::Failed, e.to_string())),
        };
        let caller = Caller {
            client: &self.client,
            interface: &self.interface,
        };
        self.unanswered.ended(&caller, outcome.call, unanswered);
        Some(outcome)
    }

    /// Tells the broker this client needs nothing any more (done on drop too).
    pub fn release(&mut self) {
        if self.released {
            return;
        }
        self.released = true;
        let message = BrokerRelease {
            client: self.client.clone(),
            ..BrokerRelease::default()
        };
        let frame = wire::request_to_vec(<BrokerRelease as Command>::NAME, &cdr::to_vec(&message));
        // Best effort: a broker that is gone needs no goodbye.
        let _ = self.broker.call(&frame, names::BROKER_CALL_TIMEOUT);
    }

    /// [`RawClient::release`], waiting (at most `timeout`) until the broker has heard it.
    ///
    /// For a process that is about to exit while the broker runs on (a finished sub-task
    /// program): a request still in flight when the process exits is dropped with its port,
    /// and the broker would then sweep the client as one that died without a release. A
    /// service stopped by the broker must not wait: the broker is busy stopping it.
    pub fn release_and_wait(&mut self, timeout: Duration) {
        if self.released {
            return;
        }
        self.released = true;
        let message = BrokerRelease {
            client: self.client.clone(),
            ..BrokerRelease::default()
        };
        // Best effort: a broker that is gone needs no goodbye.
        let _ = call_blocking(&mut self.broker, &message, timeout);
    }

    fn send_request(&mut self) {
        self.retry_at = None;
        let message = BrokerRequest {
            client: self.client.clone(),
            interface: self.interface.clone(),
            // Process ids fit in an i32 on Linux (pid_max is at most 2^22).
            pid: i32::try_from(std::process::id()).unwrap_or(0),
            ..BrokerRequest::default()
        };
        let frame = wire::request_to_vec(<BrokerRequest as Command>::NAME, &cdr::to_vec(&message));
        match self.broker.call(&frame, names::BROKER_CALL_TIMEOUT) {
            Ok(call) => self.request = Some(call),
            Err(_) => {
                self.request = None;
                self.retry_at = Some(Instant::now() + RETRY_REQUEST);
            }
        }
    }

    /// Returns the reason of a binding made from the answer.
    fn on_request_outcome(
        &mut self,
        outcome: CallOutcome,
        before: &mut Option<Option<String>>,
    ) -> Result<Option<String>, ClientError> {
        if Some(outcome.call) != self.request {
            return Ok(None);
        }
        self.request = None;
        let Ok(reply) = outcome.result else {
            self.retry_at = Some(Instant::now() + RETRY_REQUEST);
            return Ok(None);
        };
        let answer = match wire::read_reply(reply.bytes()) {
            Ok(Ok(bytes)) => {
                cdr::from_bytes::<BrokerRequestReply>(bytes).map_err(|e| ClientError::BadReply {
                    command: "request".into(),
                    reason: e.to_string(),
                })?
            }
            Ok(Err(refusal)) => {
                return Err(ClientError::BadReply {
                    command: "request".into(),
                    reason: refusal,
                });
            }
            Err(e) => {
                return Err(ClientError::BadReply {
                    command: "request".into(),
                    reason: e.to_string(),
                });
            }
        };
        match BrokerRequestReplyStatus::parse(&answer.status) {
            Some(BrokerRequestReplyStatus::Bound) => {
                self.switch_to(Some(&answer.service), before)?;
                Ok(Some("the broker's answer".to_owned()))
            }
            Some(BrokerRequestReplyStatus::Rejected) => Err(ClientError::Rejected {
                interface: self.interface.clone(),
            }),
            _ => Ok(None),
        }
    }

    /// Moves to `provider`; `before` keeps the provider held before the first switch.
    fn switch_to(
        &mut self,
        provider: Option<&str>,
        before: &mut Option<Option<String>>,
    ) -> Result<(), ClientError> {
        if self.provider.as_deref() == provider {
            return Ok(());
        }
        // The calls to the provider left behind will never be answered.
        let caller = Caller {
            client: &self.client,
            interface: &self.interface,
        };
        self.unanswered.provider_gone(&caller);
        self.commands = None;
        self.data = None;
        self.data_channel.clear();
        let previous = std::mem::replace(&mut self.provider, provider.map(str::to_owned));
        before.get_or_insert(previous);
        if let Some(provider) = provider {
            let channel = names::data_channel(provider, &self.interface);
            self.data = Some(
                self.ipc
                    .subscriber(&channel, &names::data_config(&self.interface))?,
            );
            self.data_channel = channel;
        }
        Ok(())
    }
}

impl Drop for RawClient {
    fn drop(&mut self) {
        self.release();
    }
}

/// A sample received by a [`Client`]: the message and the provider it came from.
#[derive(Debug, Clone, PartialEq)]
pub struct Sample<T> {
    /// The message (its header names its provider).
    pub message: T,
    /// The channel it came on.
    pub channel: String,
}

/// The typed client of interface `T` for an application: see the module documentation.
#[derive(Debug)]
pub struct Client<T: Interface> {
    raw: RawClient,
    waits: WaitSet,
    _interface: PhantomData<fn() -> T>,
}

impl<T: Interface> Client<T> {
    /// Asks the broker of `ipc`'s namespace for `T` on behalf of `client` (a name unique
    /// among the robot's clients). Returns at once; samples flow once the broker has bound
    /// it.
    ///
    /// # Errors
    /// When the broker's channels cannot be opened.
    pub fn connect(ipc: &Rc<Ipc>, client: &str) -> Result<Self, ClientError> {
        Ok(Self {
            raw: RawClient::new(ipc, client, T::NAME)?,
            waits: WaitSet::new(WakeMode::Event),
            _interface: PhantomData,
        })
    }

    /// Waits in `mode` (event wake-ups by default; busy polling for hard real-time).
    #[must_use]
    pub fn with_wake_mode(mut self, mode: WakeMode) -> Self {
        self.waits = WaitSet::new(mode);
        self
    }

    /// The provider it is bound to now.
    #[must_use]
    pub fn provider(&self) -> Option<&str> {
        self.raw.provider()
    }

    /// Waits until the client is bound (at most `timeout`) and returns the provider.
    ///
    /// # Errors
    /// As [`Client::try_recv`]; [`ClientError::Unbound`] when the time is up.
    pub fn wait_bound(&mut self, timeout: Duration) -> Result<String, ClientError> {
        let deadline = Instant::now() + timeout;
        loop {
            self.raw.process()?;
            if let Some(provider) = self.raw.provider() {
                return Ok(provider.to_owned());
            }
            if Instant::now() >= deadline {
                return Err(self.unbound());
            }
            self.wait(deadline)?;
        }
    }

    /// The oldest unread sample, without waiting.
    ///
    /// # Errors
    /// When the broker rejects the interface, or a sample cannot be received or decoded.
    pub fn try_recv(&mut self) -> Result<Option<Sample<T>>, ClientError> {
        let received = self.try_received()?;
        received.map(|r| self.decode(&r)).transpose()
    }

    /// The newest unread sample (older ones are skipped), without waiting.
    ///
    /// # Errors
    /// As [`Client::try_recv`].
    pub fn latest(&mut self) -> Result<Option<Sample<T>>, ClientError> {
        self.raw.process()?;
        let received = self.raw.latest()?;
        received.map(|r| self.decode(&r)).transpose()
    }

    /// The next sample, waiting at most `timeout` (the stream; `None` when the time is up).
    ///
    /// # Errors
    /// As [`Client::try_recv`].
    pub fn recv_timeout(&mut self, timeout: Duration) -> Result<Option<Sample<T>>, ClientError> {
        let received = self.received_within(timeout)?;
        received.map(|r| self.decode(&r)).transpose()
    }

    /// Reads the oldest unread sample in place, without waiting: `read` gets the
    /// message's view ([`lewis_interfaces::cdr::DecodeView`]), its arrays where they lie
    /// in shared memory, nothing copied. The sample is released when `read` returns.
    /// `None` when there is no sample.
    ///
    /// # Errors
    /// As [`Client::try_recv`].
    pub fn try_recv_view<R>(
        &mut self,
        read: impl FnOnce(T::View<'_>) -> R,
    ) -> Result<Option<R>, ClientError> {
        let received = self.try_received()?;
        received.map(|r| self.read_view(&r, read)).transpose()
    }

    /// [`Client::try_recv_view`], waiting at most `timeout` for the next sample (the
    /// stream; `None` when the time is up).
    ///
    /// # Errors
    /// As [`Client::try_recv`].
    pub fn recv_view_timeout<R>(
        &mut self,
        timeout: Duration,
        read: impl FnOnce(T::View<'_>) -> R,
    ) -> Result<Option<R>, ClientError> {
        let received = self.received_within(timeout)?;
        received.map(|r| self.read_view(&r, read)).transpose()
    }

    /// Sends a command to the current provider and waits for its reply (at most `timeout`).
    ///
    /// # Errors
    /// When unbound, when the call fails or times out, when the provider refuses it, or when
    /// the reply does not decode.
    pub fn call<C: Command<Interface = T>>(
        &mut self,
        command: &C,
        timeout: Duration,
    ) -> Result<C::Reply, ClientError> {
        self.raw.process()?;
        let provider = self.raw.provider().map(str::to_owned);
        let frame = wire::request_to_vec(C::NAME, &cdr::to_vec(command));
        let call = self.raw.call(&frame, timeout)?;
        loop {
            if let Some(outcome) = self.raw.take_call_outcome()
                && outcome.call == call
            {
                let reply = outcome.result?;
                return decode_reply::<C>(reply.bytes(), provider.as_deref().unwrap_or(""));
            }
            let sources = self.raw.waitables();
            match self.waits.wait(&sources, None)? {
                Woken::Ready(_) | Woken::DeadlineReached | Woken::Interrupted => {}
            }
        }
    }

    /// The untyped client inside, for event loops that wait on many things.
    pub fn raw_mut(&mut self) -> &mut RawClient {
        &mut self.raw
    }

    fn wait(&self, deadline: Instant) -> Result<(), ClientError> {
        let deadline = self.raw.deadline().map_or(deadline, |d| d.min(deadline));
        let sources = self.raw.waitables();
        self.waits.wait(&sources, Some(deadline))?;
        Ok(())
    }

    /// The oldest unread sample of the current provider, after the broker's news.
    fn try_received(&mut self) -> Result<Option<Received>, ClientError> {
        self.raw.process()?;
        self.raw.receive()
    }

    /// [`Client::try_received`], waiting at most `timeout` for one.
    fn received_within(&mut self, timeout: Duration) -> Result<Option<Received>, ClientError> {
        let deadline = Instant::now() + timeout;
        if self.waits.mode() == WakeMode::BusyPoll {
            return self.received_spinning(deadline);
        }
        loop {
            if let Some(received) = self.try_received()? {
                return Ok(Some(received));
            }
            if Instant::now() >= deadline {
                return Ok(None);
            }
            self.wait(deadline)?;
        }
    }

    /// [`Client::received_within`] busy polling: spins on the data channel itself, as a
    /// hand-written subscriber would, and takes in the broker's news whenever there is some.
    /// A sample is taken the moment it lands, not after a readiness check, a return through
    /// the wait set and a pass over the broker's channels (about a fifth of a microsecond).
    fn received_spinning(&mut self, deadline: Instant) -> Result<Option<Received>, ClientError> {
        self.raw.process()?;
        let mut spins: u32 = 0;
        loop {
            if let Some(received) = self.raw.receive()? {
                return Ok(Some(received));
            }
            if self.raw.has_news() {
                self.raw.process()?;
            }
            spins = spins.wrapping_add(1);
            if spins.is_multiple_of(SPINS_PER_CLOCK_READ) && Instant::now() >= deadline {
                return Ok(None);
            }
            std::hint::spin_loop();
        }
    }

    fn read_view<R>(
        &self,
        received: &Received,
        read: impl FnOnce(T::View<'_>) -> R,
    ) -> Result<R, ClientError> {
        let view = T::view(received.bytes()).map_err(|e| self.decode_error(&e))?;
        Ok(read(view))
    }

    fn decode(&self, received: &Received) -> Result<Sample<T>, ClientError> {
        let message = cdr::from_bytes::<T>(received.bytes()).map_err(|e| self.decode_error(&e))?;
        Ok(Sample {
            message,
            channel: self.raw.data_channel().to_owned(),
        })
    }

    fn decode_error(&self, error: &cdr::DecodeError) -> ClientError {
        ClientError::Decode {
            interface: T::NAME.to_owned(),
            provider: self.raw.provider().unwrap_or_default().to_owned(),
            reason: error.to_string(),
        }
    }

    fn unbound(&self) -> ClientError {
        ClientError::Unbound {
            client: self.raw.client().to_owned(),
            interface: T::NAME.to_owned(),
        }
    }
}

/// Decodes a reply frame as the reply of `C`.
fn decode_reply<C: Command>(frame: &[u8], provider: &str) -> Result<C::Reply, ClientError> {
    let bad = |reason: String| ClientError::BadReply {
        command: C::NAME.to_owned(),
        reason,
    };
    match wire::read_reply(frame).map_err(|e| bad(e.to_string()))? {
        Ok(bytes) => cdr::from_bytes(bytes).map_err(|e| bad(e.to_string())),
        Err(reason) => Err(ClientError::Refused {
            interface: <C::Interface as Interface>::NAME.to_owned(),
            command: C::NAME.to_owned(),
            provider: provider.to_owned(),
            reason,
        }),
    }
}

/// Calls command `C` on a command channel and waits for the reply (for tools such as
/// `lewis status`, which talk to the broker directly).
///
/// # Errors
/// When the call fails, times out, is refused, or the reply does not decode.
pub fn call_blocking<C: Command>(
    client: &mut CommandClient,
    command: &C,
    timeout: Duration,
) -> Result<C::Reply, ClientError> {
    let frame = wire::request_to_vec(C::NAME, &cdr::to_vec(command));
    let reply = client.call_blocking(
        frame.len(),
        timeout,
        |buf| buf.copy_from_slice(&frame),
        WakeMode::Event,
    )?;
    decode_reply::<C>(reply.bytes(), "")
}
