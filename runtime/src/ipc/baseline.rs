//! The baseline of the latency benchmarks: raw iceoryx2 publish-subscribe of a byte slice,
//! with an iceoryx2 event service for the wake-ups, as an application would write it by
//! hand, none of our layers in the way. `runtime/benches/ipc_latency` compares our layers
//! with it, and `tests/benches/reflex` puts the reflex latency beside its one hop.
//!
//! The publisher stamps the first 8 bytes of each sample with a time of the caller's
//! choosing (the benchmarks use `CLOCK_MONOTONIC`, one clock for every process); the
//! receiver hands the stamp back.

use std::mem::MaybeUninit;
use std::time::{Duration, Instant};

use iceoryx2::config::Config;
use iceoryx2::node::Node;
use iceoryx2::prelude::{
    AllocationStrategy, FileName, NodeBuilder, SemanticString, ServiceName, SignalHandlingMode, ipc,
};
use iceoryx2::service::port_factory::{event, publish_subscribe};

use super::Namespace;

/// Samples a subscriber buffers: the byte layer's channels in the benchmark use the same
/// limits, so both preallocate the same chunks (same memory, same page-fault pattern).
pub const BUFFER: usize = 8;
/// Samples a subscriber may hold at once.
pub const MAX_HELD: usize = 2;
/// Subscribers per channel.
pub const MAX_SUBSCRIBERS: usize = 8;
/// Publishers per channel.
pub const MAX_PUBLISHERS: usize = 2;

/// A failure of iceoryx2, as its text.
#[derive(Debug, thiserror::Error)]
#[error("raw iceoryx2: {0}")]
pub struct BaselineError(String);

fn fail(e: impl std::fmt::Display) -> BaselineError {
    BaselineError(e.to_string())
}

/// How the receiver waits for a sample.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Wake {
    /// Blocked on the event service; the publisher notifies after each sample.
    Event,
    /// Spinning on the subscriber; no notification.
    BusyPoll,
}

/// How the publisher writes a payload into its loan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fill {
    /// A constant byte: a memset, the least a publisher can do.
    Pattern,
    /// A copy of a message the publisher holds in its own memory (as a typed publisher
    /// encodes its message into the loan).
    CopyIn,
}

fn node(namespace: &Namespace) -> Result<Node<ipc::Service>, BaselineError> {
    let mut config = Config::default();
    config.global.prefix =
        FileName::new(format!("bench-raw.{namespace}.").as_bytes()).map_err(fail)?;
    NodeBuilder::new()
        .config(&config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .map_err(fail)
}

type Services = (
    publish_subscribe::PortFactory<ipc::Service, [u8], ()>,
    event::PortFactory<ipc::Service>,
);

fn services(node: &Node<ipc::Service>, len: usize) -> Result<Services, BaselineError> {
    let name = ServiceName::new(&format!("raw/{len}")).map_err(fail)?;
    let data = node
        .service_builder(&name)
        .publish_subscribe::<[u8]>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(BUFFER)
        .subscriber_max_borrowed_samples(MAX_HELD)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(MAX_PUBLISHERS)
        .history_size(0)
        .open_or_create()
        .map_err(fail)?;
    let events = node
        .service_builder(&name)
        .event()
        .open_or_create()
        .map_err(fail)?;
    Ok((data, events))
}

fn stamp(bytes: &[u8]) -> u64 {
    let mut t = [0u8; 8];
    if let Some(head) = bytes.get(..8) {
        t.copy_from_slice(head);
    }
    u64::from_le_bytes(t)
}

/// The receiving end of the baseline.
pub struct RawReceiver {
    // The ports before the node that owns them.
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    sub: iceoryx2::port::subscriber::Subscriber<ipc::Service, [u8], ()>,
    _node: Node<ipc::Service>,
    wake: Wake,
}

impl RawReceiver {
    /// Subscribes to the baseline's channel of `len`-byte samples in `namespace`.
    ///
    /// # Errors
    /// When iceoryx2 cannot open the node, the services or the ports.
    pub fn open(namespace: &Namespace, wake: Wake, len: usize) -> Result<Self, BaselineError> {
        let node = node(namespace)?;
        let (data, events) = services(&node, len)?;
        Ok(Self {
            listener: events.listener_builder().create().map_err(fail)?,
            sub: data
                .subscriber_builder()
                .buffer_size(BUFFER)
                .create()
                .map_err(fail)?,
            _node: node,
            wake,
        })
    }

    /// The stamp of the next sample, once it is in hand; `None` after `idle_limit` without
    /// one.
    ///
    /// # Errors
    /// When iceoryx2 fails to receive or to wait.
    pub fn next(&self, idle_limit: Duration) -> Result<Option<u64>, BaselineError> {
        let deadline = Instant::now() + idle_limit;
        let mut spins: u32 = 0;
        loop {
            if let Some(sample) = self.sub.receive().map_err(fail)? {
                return Ok(Some(stamp(sample.payload())));
            }
            if self.wake == Wake::Event {
                self.listener.timed_wait(|_| {}, idle_limit).map_err(fail)?;
            } else {
                std::hint::spin_loop();
            }
            spins = spins.wrapping_add(1);
            // An event wait is long enough to read the clock after each one.
            let check = self.wake == Wake::Event || spins.is_multiple_of(64);
            if check && Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }
}

/// The sending end of the baseline: loan, fill as [`Fill`] says, stamp, send, and notify
/// when the receiver waits on events.
pub struct RawPublisher {
    // The ports before the node that owns them.
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    publisher: iceoryx2::port::publisher::Publisher<ipc::Service, [u8], ()>,
    _node: Node<ipc::Service>,
    wake: Wake,
    fill: Fill,
    message: Vec<u8>,
}

impl RawPublisher {
    /// Publishes `message` (its first 8 bytes replaced by the stamp) on the baseline's
    /// channel of its length in `namespace`.
    ///
    /// # Errors
    /// When iceoryx2 cannot open the node, the services or the ports.
    pub fn open(
        namespace: &Namespace,
        wake: Wake,
        fill: Fill,
        message: Vec<u8>,
    ) -> Result<Self, BaselineError> {
        let node = node(namespace)?;
        let (data, events) = services(&node, message.len())?;
        Ok(Self {
            notifier: events.notifier_builder().create().map_err(fail)?,
            publisher: data
                .publisher_builder()
                .initial_max_slice_len(message.len())
                .allocation_strategy(AllocationStrategy::PowerOfTwo)
                .create()
                .map_err(fail)?,
            _node: node,
            wake,
            fill,
            message,
        })
    }

    /// Publishes one sample stamped with `stamp` (the time the publication started).
    ///
    /// # Errors
    /// When iceoryx2 cannot loan, send or notify.
    pub fn send(&self, stamp: u64) -> Result<(), BaselineError> {
        let sample = self
            .publisher
            .loan_slice_uninit(self.message.len())
            .map_err(fail)?;
        let mut sample = match self.fill {
            Fill::Pattern => {
                let mut sample = sample;
                sample.payload_mut().fill(MaybeUninit::new(0x5a));
                // SAFETY: every byte was written just above.
                unsafe { sample.assume_init() }
            }
            Fill::CopyIn => sample.write_from_slice(&self.message),
        };
        if let Some(head) = sample.payload_mut().get_mut(..8) {
            head.copy_from_slice(&stamp.to_le_bytes());
        }
        sample.send().map_err(fail)?;
        if self.wake == Wake::Event {
            self.notifier.notify().map_err(fail)?;
        }
        Ok(())
    }
}
