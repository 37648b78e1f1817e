//! IPC over iceoryx2: publish-subscribe of CDR bytes, commands, events, all under a namespace.
//!
//! This is the untyped layer: payloads are the bytes of a message, written in place into
//! loaned shared memory by an encoder `FnOnce(&mut [u8])` once the caller has said the
//! exact length. The typed layer (`Client<RangeFinder>`, `ctx.publish`) sits on top.
//!
//! - [`Namespace`]: every name lives under `LEWIS_NAMESPACE` (iceoryx2's global prefix).
//! - [`Ipc`]: one iceoryx2 node per process (or per test); it makes every port below.
//! - [`Publisher`] / [`Subscriber`]: a data channel, with per-channel buffer, overflow policy
//!   and history ([`ChannelConfig`]); each is paired with an iceoryx2 event service so that
//!   receivers can block instead of polling.
//! - [`CommandServer`] / [`CommandClient`]: commands over iceoryx2 request-response, with a
//!   timeout that turns into an error.
//! - [`WaitSet`]: waits on many subscribers, servers, clients and file descriptors at once,
//!   with a deadline, in event, adaptive (spin then block), predictive (block until a
//!   periodic sample is due, then spin) or busy-poll mode.
//! - [`Ipc::nodes`] / [`Ipc::cleanup_dead_nodes`]: liveness of the processes in the
//!   namespace, the only way to see a publisher that was killed with SIGKILL;
//!   [`NodeCleaner`] cleans on a thread of its own, for loops that must not stall.
//! - [`LedgerReader`]: what each publisher of a process that died had sent (every
//!   publisher notes its count in a small mapped file that outlives it), so that a reader
//!   counts the samples a killed provider sent that never arrived.
//! - [`wipe_stale`] / [`wipe_orphaned_namespaces`]: what runs that died left in a namespace,
//!   or in the namespaces of test runs that have ended, removed.
//! - [`baseline`]: raw iceoryx2, none of the above, for the latency benchmarks to compare
//!   with.

pub mod baseline;
mod channel;
mod cleaner;
mod command;
mod ledger;
mod liveness;
mod namespace;
mod orphans;
mod predict;
mod stale;
mod wait;

pub use channel::{
    ChannelConfig, Drain, OverflowPolicy, PublishError, Published, Publisher, ReceiveError,
    Received, Subscriber,
};
pub use cleaner::NodeCleaner;
pub use command::{
    CallError, CallId, CallOutcome, CommandClient, CommandConfig, CommandServer, Reply, ReplyError,
    Request,
};
pub use ledger::{EndedPublisher, LedgerReader};
pub use liveness::{CleanupReport, LivenessError, NodeInfo, NodeLiveness};
pub use namespace::{
    DEFAULT_NAMESPACE, MAX_NAMESPACE_LEN, NAMESPACE_ENV, Namespace, NamespaceError,
};
pub use orphans::{OrphanReport, wipe_orphaned_namespaces};
pub use stale::{
    WipeReport, remove_abandoned_channels, remove_abandoned_memory, wipe_ended, wipe_stale,
};
pub(crate) use wait::SPINS_PER_CLOCK_READ;
pub use wait::{FdSource, Fired, MAX_WAIT_SOURCES, WaitError, WaitSet, Waitable, WakeMode, Woken};

use std::cell::{OnceCell, RefCell};
use std::collections::BTreeMap;
use std::rc::Rc;
use std::sync::Arc;

use iceoryx2::node::{Node, NodeBuilder};
use iceoryx2::prelude::{NodeName, ServiceName, SignalHandlingMode, ipc};

/// Why an IPC endpoint could not be set up.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum IpcError {
    /// The namespace name is not valid.
    #[error(transparent)]
    Namespace(#[from] NamespaceError),
    /// A node, channel or command name is not accepted by iceoryx2.
    #[error("{kind} name `{name}` is not valid: {reason}")]
    InvalidName {
        /// What the name is for (`node`, `channel`, `command`).
        kind: &'static str,
        /// The refused name.
        name: String,
        /// What iceoryx2 said.
        reason: String,
    },
    /// The iceoryx2 node could not be created (permissions on /tmp/iceoryx2 or /dev/shm).
    #[error(
        "cannot create IPC node `{node}` in namespace `{namespace}`: {reason}; check that /tmp/iceoryx2 and /dev/shm are writable"
    )]
    Node {
        /// The node name.
        node: String,
        /// The namespace.
        namespace: String,
        /// What iceoryx2 said.
        reason: String,
    },
    /// A service could not be opened or created, typically because another process created
    /// it with different settings (buffer size, overflow policy, limits).
    #[error(
        "cannot open {pattern} `{name}` in namespace `{namespace}`: {reason}; both sides must use the same settings"
    )]
    Service {
        /// `channel`, `channel event`, `command` or `command event`.
        pattern: &'static str,
        /// The name given by the caller.
        name: String,
        /// The namespace.
        namespace: String,
        /// What iceoryx2 said.
        reason: String,
    },
    /// A port (publisher, subscriber, server, client, notifier, listener) could not be made,
    /// typically because the service's limit for that port kind is reached.
    #[error(
        "cannot create {port} for `{name}`: {reason}; raise the limit in its config if too many are in use"
    )]
    Port {
        /// The port kind.
        port: &'static str,
        /// The channel or command name.
        name: String,
        /// What iceoryx2 said.
        reason: String,
    },
}

/// The environment variable that sets iceoryx2's own log level (`warn`, `info`, ...).
pub const ICEORYX2_LOG_ENV: &str = "IOX2_LOG_LEVEL";

/// Lets iceoryx2 say only errors, unless [`ICEORYX2_LOG_ENV`] asks for more: its warnings
/// are its housekeeping (a dead node's resources cleaned up, the default configuration
/// used), which Lewis expects and reports in its own words, and they would otherwise fill a
/// person's terminal whenever a service is killed.
fn quiet_iceoryx2() {
    static ONCE: std::sync::Once = std::sync::Once::new();
    ONCE.call_once(|| {
        iceoryx2::prelude::set_log_level_from_env_or(iceoryx2::prelude::LogLevel::Error);
    });
}

/// The IPC endpoint of one process (an iceoryx2 node) in one namespace: it makes publishers,
/// subscribers, command servers and clients, and sees the other nodes of the namespace.
#[derive(Debug)]
pub struct Ipc {
    /// The publishers every part of this process shares ([`Ipc::shared_publisher`]); before
    /// `node`, so that they close before it.
    shared: RefCell<BTreeMap<String, Rc<RefCell<Publisher>>>>,
    /// This endpoint's publication ledger, made with its first publisher.
    ledger: OnceCell<Option<Arc<ledger::LedgerFile>>>,
    node: Node<ipc::Service>,
    namespace: Namespace,
}

impl Ipc {
    /// Joins `namespace` as the node `node_name` (shown in node lists; the service's name is
    /// a good choice). Creating a node also removes what dead nodes of the namespace left.
    pub fn open(namespace: &Namespace, node_name: &str) -> Result<Self, IpcError> {
        quiet_iceoryx2();
        let config = namespace.iceoryx2_config()?;
        let name = NodeName::new(node_name).map_err(|e| IpcError::InvalidName {
            kind: "node",
            name: node_name.to_owned(),
            reason: e.to_string(),
        })?;
        // We never call iceoryx2's own wait functions, and the process supervisor owns
        // SIGTERM/SIGINT: iceoryx2 must not install handlers that swallow them.
        let node = NodeBuilder::new()
            .name(&name)
            .config(&config)
            .signal_handling_mode(SignalHandlingMode::Disabled)
            .create::<ipc::Service>()
            .map_err(|e| IpcError::Node {
                node: node_name.to_owned(),
                namespace: namespace.to_string(),
                reason: e.to_string(),
            })?;
        Ok(Self {
            shared: RefCell::new(BTreeMap::new()),
            ledger: OnceCell::new(),
            node,
            namespace: namespace.clone(),
        })
    }

    /// The one publisher of this process on `channel`, opened at the first call: for a
    /// channel that every part of a process may write to (`/lewis/calls`), so that the
    /// process counts once against the channel's publishers, and its publisher is there
    /// (and the recorder connected to it) before the first message.
    ///
    /// # Errors
    /// When the channel cannot be opened.
    pub fn shared_publisher(
        &self,
        channel: &str,
        config: &ChannelConfig,
    ) -> Result<Rc<RefCell<Publisher>>, IpcError> {
        if let Some(publisher) = self.shared.borrow().get(channel) {
            return Ok(Rc::clone(publisher));
        }
        let publisher = Rc::new(RefCell::new(self.publisher(channel, config)?));
        self.shared
            .borrow_mut()
            .insert(channel.to_owned(), Rc::clone(&publisher));
        Ok(publisher)
    }

    /// Joins the namespace named by `LEWIS_NAMESPACE` (default `default`).
    pub fn open_from_env(node_name: &str) -> Result<Self, IpcError> {
        Self::open(&Namespace::from_env()?, node_name)
    }

    /// The namespace this endpoint lives in.
    pub fn namespace(&self) -> &Namespace {
        &self.namespace
    }

    /// This node's id as it appears in [`Ipc::nodes`].
    pub fn node_id(&self) -> u128 {
        self.node.id().value()
    }

    pub(crate) fn node(&self) -> &Node<ipc::Service> {
        &self.node
    }

    pub(crate) fn service_error(
        &self,
        pattern: &'static str,
        name: &str,
        reason: impl std::fmt::Display,
    ) -> IpcError {
        IpcError::Service {
            pattern,
            name: name.to_owned(),
            namespace: self.namespace.to_string(),
            reason: reason.to_string(),
        }
    }
}

pub(crate) fn port_error(
    port: &'static str,
    name: &str,
    reason: impl std::fmt::Display,
) -> IpcError {
    IpcError::Port {
        port,
        name: name.to_owned(),
        reason: reason.to_string(),
    }
}

/// The iceoryx2 service name `{family}/{name}`: the family keeps data channels and commands
/// of the same name apart.
pub(crate) fn service_name(
    kind: &'static str,
    family: &str,
    name: &str,
) -> Result<ServiceName, IpcError> {
    ServiceName::new(&format!("{family}/{name}")).map_err(|e| IpcError::InvalidName {
        kind,
        name: name.to_owned(),
        reason: e.to_string(),
    })
}
