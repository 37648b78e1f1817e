//! Commands: iceoryx2 request-response of byte slices, one reply per request, with a
//! timeout that becomes an error. Each direction is paired with an event service so that
//! servers and clients can block in a [`WaitSet`](super::WaitSet).

use std::fmt;
use std::os::fd::BorrowedFd;
use std::time::{Duration, Instant};

use iceoryx2::active_request::ActiveRequest;
use iceoryx2::pending_response::PendingResponse;
use iceoryx2::port::client::{Client, RequestSendError};
use iceoryx2::port::listener::Listener;
use iceoryx2::port::notifier::Notifier;
use iceoryx2::port::server::Server;
use iceoryx2::prelude::{AllocationStrategy, ipc};
use iceoryx2::response::Response;
use iceoryx2::service::port_factory::{event, request_response};

use super::wait::{self, WaitSet, Waitable, WakeMode, Woken};
use super::{Ipc, IpcError, WaitError, port_error, service_name};

/// The service family of commands (`cmd/NAME`), apart from data channels.
const FAMILY: &str = "cmd";
/// The event service that wakes servers when a request arrives.
const REQUESTS_EVENT: &str = "cmd-requests";
/// The event service that wakes clients when a reply arrives.
const REPLIES_EVENT: &str = "cmd-replies";

type RequestResponseFactory = request_response::PortFactory<ipc::Service, [u8], (), [u8], ()>;

/// The settings of one command. Servers and clients must use the same settings.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct CommandConfig {
    /// Calls one client may have outstanding at once.
    pub max_pending: usize,
    /// Clients the command accepts.
    pub max_clients: usize,
    /// Servers the command accepts (more than one means every server gets every request).
    pub max_servers: usize,
    /// Bytes preallocated per request and reply; longer ones grow the segment.
    pub initial_max_len_bytes: usize,
    /// The longest request or reply accepted.
    pub max_len_bytes: usize,
}

impl Default for CommandConfig {
    /// 8 outstanding calls per client, 16 clients, 2 servers, 1 KiB preallocated, 16 MiB
    /// at most.
    fn default() -> Self {
        Self {
            max_pending: 8,
            max_clients: 16,
            max_servers: 2,
            initial_max_len_bytes: 1024,
            max_len_bytes: 16 << 20,
        }
    }
}

/// Identifies one call of a [`CommandClient`] (increasing, unique per client).
#[derive(Debug, Clone, Copy, PartialEq, Eq, PartialOrd, Ord, Hash)]
pub struct CallId(pub u64);

/// Why a call failed. Every call ends, with a reply or one of these.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum CallError {
    /// No server was connected when the request was sent: nobody will ever answer.
    #[error("no server for command `{command}`: start the service that provides it")]
    NoServer {
        /// The command.
        command: String,
    },
    /// No reply came within the timeout.
    #[error("command `{command}` got no reply within {timeout:?}: its server is stalled or busy")]
    Timeout {
        /// The command.
        command: String,
        /// The timeout of the call.
        timeout: Duration,
    },
    /// The client already has `max_pending` calls outstanding.
    #[error(
        "command `{command}` already has {max_pending} calls outstanding: wait for their replies or raise max_pending"
    )]
    TooManyPending {
        /// The command.
        command: String,
        /// The limit.
        max_pending: usize,
    },
    /// The request is longer than `max_len_bytes`.
    #[error(
        "request of {len_bytes} bytes for command `{command}` exceeds its limit of {max_len_bytes} bytes"
    )]
    TooLarge {
        /// The command.
        command: String,
        /// The request length.
        len_bytes: usize,
        /// The limit.
        max_len_bytes: usize,
    },
    /// iceoryx2 failed to loan, send, notify or receive.
    #[error("command `{command}` failed in IPC: {reason}")]
    Transport {
        /// The command.
        command: String,
        /// What iceoryx2 said.
        reason: String,
    },
    /// Waiting for the reply failed.
    #[error("waiting for the reply to command `{command}` failed: {source}")]
    Wait {
        /// The command.
        command: String,
        /// The wait failure.
        source: WaitError,
    },
}

/// Why a server could not receive a request or send a reply.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum ReplyError {
    /// The reply is longer than `max_len_bytes`.
    #[error(
        "reply of {len_bytes} bytes for command `{command}` exceeds its limit of {max_len_bytes} bytes"
    )]
    TooLarge {
        /// The command.
        command: String,
        /// The reply length.
        len_bytes: usize,
        /// The limit.
        max_len_bytes: usize,
    },
    /// iceoryx2 failed to receive, loan, send or notify.
    #[error("server of command `{command}` failed in IPC: {reason}")]
    Transport {
        /// The command.
        command: String,
        /// What iceoryx2 said.
        reason: String,
    },
}

/// How one call ended.
#[derive(Debug)]
pub struct CallOutcome {
    /// The call.
    pub call: CallId,
    /// Its reply or why there is none.
    pub result: Result<Reply, CallError>,
}

/// A reply, borrowed from shared memory until dropped.
pub struct Reply {
    response: Response<ipc::Service, [u8], ()>,
}

impl Reply {
    /// The reply bytes.
    pub fn bytes(&self) -> &[u8] {
        self.response.payload()
    }
}

impl fmt::Debug for Reply {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Reply")
            .field("len_bytes", &self.bytes().len())
            .finish()
    }
}

/// A request received by a server; answer it with [`CommandServer::reply_with`]. Dropping it
/// unanswered leaves the caller to its timeout.
pub struct Request {
    active: ActiveRequest<ipc::Service, [u8], (), [u8], ()>,
}

impl Request {
    /// The request bytes.
    pub fn bytes(&self) -> &[u8] {
        self.active.payload()
    }

    /// The id of the client that sent it (unique on this machine).
    pub fn client_id(&self) -> u128 {
        self.active.origin().value()
    }
}

impl fmt::Debug for Request {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("Request")
            .field("len_bytes", &self.bytes().len())
            .finish()
    }
}

/// The answering end of a command.
pub struct CommandServer {
    command: String,
    port: Server<ipc::Service, [u8], (), [u8], ()>,
    request_listener: Listener<ipc::Service>,
    reply_notifier: Notifier<ipc::Service>,
    max_len_bytes: usize,
}

impl fmt::Debug for CommandServer {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CommandServer")
            .field("command", &self.command)
            .finish_non_exhaustive()
    }
}

impl CommandServer {
    /// Takes the oldest unanswered request, if any.
    pub fn receive(&self) -> Result<Option<Request>, ReplyError> {
        self.port
            .receive()
            .map(|active| active.map(|active| Request { active }))
            .map_err(|e| self.transport(e))
    }

    /// Answers `request` with exactly `len_bytes` bytes written in place by `encode`, and
    /// wakes the clients.
    pub fn reply_with<F: FnOnce(&mut [u8])>(
        &self,
        request: Request,
        len_bytes: usize,
        encode: F,
    ) -> Result<(), ReplyError> {
        if len_bytes > self.max_len_bytes {
            return Err(ReplyError::TooLarge {
                command: self.command.clone(),
                len_bytes,
                max_len_bytes: self.max_len_bytes,
            });
        }
        let response = request
            .active
            .loan_slice_uninit(len_bytes)
            .map_err(|e| self.transport(e))?;
        // SAFETY: as for publications (see `Publisher::publish_with`): the payload is `u8`s
        // in mmap-ed shared memory that only ever holds `u8` payloads, so every byte is
        // already a valid `u8`.
        let mut response = unsafe { response.assume_init() };
        encode(response.payload_mut());
        response.send().map_err(|e| self.transport(e))?;
        // One reply per request: releasing the request tells the client that no more
        // replies follow.
        drop(request);
        self.reply_notifier
            .notify()
            .map_err(|e| self.transport(e))?;
        Ok(())
    }

    /// Answers `request` with a copy of `bytes`.
    pub fn reply(&self, request: Request, bytes: &[u8]) -> Result<(), ReplyError> {
        self.reply_with(request, bytes.len(), |buf| buf.copy_from_slice(bytes))
    }

    /// The command name.
    pub fn command(&self) -> &str {
        &self.command
    }

    fn transport(&self, reason: impl fmt::Display) -> ReplyError {
        ReplyError::Transport {
            command: self.command.clone(),
            reason: reason.to_string(),
        }
    }
}

impl wait::sealed::Source for CommandServer {
    fn is_ready(&self) -> bool {
        // A connection failure reports true so that the caller's next receive returns it.
        self.port.has_requests().unwrap_or(true)
    }

    fn wake_fd(&self) -> Option<BorrowedFd<'_>> {
        Some(wait::listener_fd(&self.request_listener))
    }

    fn drain_wake(&self) {
        wait::drain_listener(&self.request_listener);
    }
}

impl Waitable for CommandServer {}

struct PendingCall {
    id: CallId,
    response: PendingResponse<ipc::Service, [u8], (), [u8], ()>,
    timeout: Duration,
    deadline: Instant,
}

/// The calling end of a command. Calls are asynchronous: [`CommandClient::call_with`] sends,
/// [`CommandClient::take_outcome`] (after a [`WaitSet`] wake-up) hands back each reply or
/// timeout; [`CommandClient::call_blocking`] does both.
pub struct CommandClient {
    command: String,
    port: Client<ipc::Service, [u8], (), [u8], ()>,
    request_notifier: Notifier<ipc::Service>,
    reply_listener: Listener<ipc::Service>,
    /// Outstanding calls, oldest first; at most `max_pending`.
    pending: Vec<PendingCall>,
    next_call: u64,
    max_pending: usize,
    max_len_bytes: usize,
}

impl fmt::Debug for CommandClient {
    fn fmt(&self, f: &mut fmt::Formatter<'_>) -> fmt::Result {
        f.debug_struct("CommandClient")
            .field("command", &self.command)
            .field("pending", &self.pending.len())
            .finish_non_exhaustive()
    }
}

impl CommandClient {
    /// Sends a request of exactly `len_bytes` bytes written in place by `encode`; its
    /// outcome (reply or [`CallError::Timeout`] after `timeout`) comes from
    /// [`CommandClient::take_outcome`]. Fails at once with [`CallError::NoServer`] when no
    /// server is connected.
    pub fn call_with<F: FnOnce(&mut [u8])>(
        &mut self,
        len_bytes: usize,
        timeout: Duration,
        encode: F,
    ) -> Result<CallId, CallError> {
        if len_bytes > self.max_len_bytes {
            return Err(CallError::TooLarge {
                command: self.command.clone(),
                len_bytes,
                max_len_bytes: self.max_len_bytes,
            });
        }
        if self.pending.len() >= self.max_pending {
            return Err(self.too_many_pending());
        }
        let request = self
            .port
            .loan_slice_uninit(len_bytes)
            .map_err(|e| self.transport(e))?;
        // SAFETY: as for publications (see `Publisher::publish_with`): the payload is `u8`s
        // in mmap-ed shared memory that only ever holds `u8` payloads, so every byte is
        // already a valid `u8`.
        let mut request = unsafe { request.assume_init() };
        encode(request.payload_mut());
        let response = request.send().map_err(|e| match e {
            RequestSendError::ExceedsMaxActiveRequests => self.too_many_pending(),
            e => self.transport(e),
        })?;
        if response.number_of_server_connections() == 0 {
            return Err(CallError::NoServer {
                command: self.command.clone(),
            });
        }
        self.request_notifier
            .notify()
            .map_err(|e| self.transport(e))?;
        let id = CallId(self.next_call);
        self.next_call += 1;
        self.pending.push(PendingCall {
            id,
            response,
            timeout,
            deadline: Instant::now() + timeout,
        });
        Ok(id)
    }

    /// Sends a copy of `bytes` (see [`CommandClient::call_with`]).
    pub fn call(&mut self, bytes: &[u8], timeout: Duration) -> Result<CallId, CallError> {
        self.call_with(bytes.len(), timeout, |buf| buf.copy_from_slice(bytes))
    }

    /// Hands back one finished call (replied, timed out or failed), oldest first, or `None`
    /// when every outstanding call is still waiting.
    pub fn take_outcome(&mut self) -> Option<CallOutcome> {
        let now = Instant::now();
        let index = (0..self.pending.len()).find(|&i| self.is_finished(i, now))?;
        Some(self.finish(index))
    }

    /// The outcome of `call` if it has finished (see [`CommandClient::take_outcome`]).
    pub fn outcome_of(&mut self, call: CallId) -> Option<Result<Reply, CallError>> {
        let index = self.pending.iter().position(|p| p.id == call)?;
        if self.is_finished(index, Instant::now()) {
            Some(self.finish(index).result)
        } else {
            None
        }
    }

    /// Sends a request and waits for its reply or its timeout, in `mode`.
    pub fn call_blocking<F: FnOnce(&mut [u8])>(
        &mut self,
        len_bytes: usize,
        timeout: Duration,
        encode: F,
        mode: WakeMode,
    ) -> Result<Reply, CallError> {
        let call = self.call_with(len_bytes, timeout, encode)?;
        let waits = WaitSet::new(mode);
        loop {
            if let Some(result) = self.outcome_of(call) {
                return result;
            }
            // The call's own deadline bounds the wait.
            match waits.wait(&[&*self], None) {
                Ok(Woken::Ready(_) | Woken::DeadlineReached | Woken::Interrupted) => {}
                Err(source) => {
                    return Err(CallError::Wait {
                        command: self.command.clone(),
                        source,
                    });
                }
            }
        }
    }

    /// Calls sent and not yet handed back.
    pub fn pending(&self) -> usize {
        self.pending.len()
    }

    /// Whether a call has an outcome to take: its reply came, or its time is up (no system
    /// call).
    pub fn has_outcome(&self) -> bool {
        if self.pending.is_empty() {
            return false;
        }
        let now = Instant::now();
        (0..self.pending.len()).any(|i| self.is_finished(i, now))
    }

    /// The command name.
    pub fn command(&self) -> &str {
        &self.command
    }

    fn is_finished(&self, index: usize, now: Instant) -> bool {
        let call = &self.pending[index];
        call.response.has_response() || now >= call.deadline
    }

    fn finish(&mut self, index: usize) -> CallOutcome {
        let call = self.pending.remove(index);
        let result = match call.response.receive() {
            Ok(Some(response)) => Ok(Reply { response }),
            Ok(None) => Err(CallError::Timeout {
                command: self.command.clone(),
                timeout: call.timeout,
            }),
            Err(e) => Err(self.transport(e)),
        };
        CallOutcome {
            call: call.id,
            result,
        }
    }

    fn too_many_pending(&self) -> CallError {
        CallError::TooManyPending {
            command: self.command.clone(),
            max_pending: self.max_pending,
        }
    }

    fn transport(&self, reason: impl fmt::Display) -> CallError {
        CallError::Transport {
            command: self.command.clone(),
            reason: reason.to_string(),
        }
    }
}

impl wait::sealed::Source for CommandClient {
    fn is_ready(&self) -> bool {
        self.has_outcome()
    }

    fn wake_fd(&self) -> Option<BorrowedFd<'_>> {
        Some(wait::listener_fd(&self.reply_listener))
    }

    fn drain_wake(&self) {
        wait::drain_listener(&self.reply_listener);
    }

    fn deadline(&self) -> Option<Instant> {
        self.pending.iter().map(|p| p.deadline).min()
    }
}

impl Waitable for CommandClient {}

impl Ipc {
    fn open_command(
        &self,
        command: &str,
        config: &CommandConfig,
    ) -> Result<
        (
            RequestResponseFactory,
            event::PortFactory<ipc::Service>,
            event::PortFactory<ipc::Service>,
        ),
        IpcError,
    > {
        let max_nodes = config.max_clients + config.max_servers;
        let name = service_name("command", FAMILY, command)?;
        let service = self
            .node()
            .service_builder(&name)
            .request_response::<[u8], [u8]>()
            .max_active_requests_per_client(config.max_pending.max(1))
            .max_clients(config.max_clients.max(1))
            .max_servers(config.max_servers.max(1))
            .max_nodes(max_nodes)
            .open_or_create()
            .map_err(|e| self.service_error("command", command, e))?;
        let open_event = |family: &str, listeners: usize, notifiers: usize| {
            let name = service_name("command", family, command)?;
            self.node()
                .service_builder(&name)
                .event()
                .max_listeners(listeners.max(1))
                .max_notifiers(notifiers.max(1))
                .max_nodes(max_nodes)
                .open_or_create()
                .map_err(|e| self.service_error("command event", command, e))
        };
        let requests = open_event(REQUESTS_EVENT, config.max_servers, config.max_clients)?;
        let replies = open_event(REPLIES_EVENT, config.max_clients, config.max_servers)?;
        Ok((service, requests, replies))
    }

    /// Opens (or creates) the command `command` and serves it.
    pub fn command_server(
        &self,
        command: &str,
        config: &CommandConfig,
    ) -> Result<CommandServer, IpcError> {
        let (service, requests, replies) = self.open_command(command, config)?;
        let request_listener = requests
            .listener_builder()
            .create()
            .map_err(|e| port_error("listener", command, e))?;
        let port = service
            .server_builder()
            .initial_max_slice_len(config.initial_max_len_bytes.max(1))
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| port_error("server", command, e))?;
        let reply_notifier = replies
            .notifier_builder()
            .create()
            .map_err(|e| port_error("notifier", command, e))?;
        Ok(CommandServer {
            command: command.to_owned(),
            port,
            request_listener,
            reply_notifier,
            max_len_bytes: config.max_len_bytes,
        })
    }

    /// Opens (or creates) the command `command` to call it.
    pub fn command_client(
        &self,
        command: &str,
        config: &CommandConfig,
    ) -> Result<CommandClient, IpcError> {
        let (service, requests, replies) = self.open_command(command, config)?;
        let reply_listener = replies
            .listener_builder()
            .create()
            .map_err(|e| port_error("listener", command, e))?;
        let port = service
            .client_builder()
            .initial_max_slice_len(config.initial_max_len_bytes.max(1))
            .allocation_strategy(AllocationStrategy::PowerOfTwo)
            .create()
            .map_err(|e| port_error("client", command, e))?;
        let request_notifier = requests
            .notifier_builder()
            .create()
            .map_err(|e| port_error("notifier", command, e))?;
        Ok(CommandClient {
            command: command.to_owned(),
            port,
            request_notifier,
            reply_listener,
            pending: Vec::new(),
            next_call: 0,
            max_pending: config.max_pending.max(1),
            max_len_bytes: config.max_len_bytes,
        })
    }
}
