//! The baseline: raw iceoryx2 publish-subscribe of a byte slice, with an iceoryx2 event
//! service for the wake-ups, as an application would write it by hand.

use std::mem::MaybeUninit;
use std::time::Instant;

use iceoryx2::config::Config;
use iceoryx2::node::Node;
use iceoryx2::prelude::{
    AllocationStrategy, FileName, NodeBuilder, SemanticString, ServiceName, SignalHandlingMode, ipc,
};
use iceoryx2::service::port_factory::{event, publish_subscribe};
use lewis_runtime::ipc::Namespace;

use crate::bytes::{BUFFER, MAX_HELD, MAX_PUBLISHERS, MAX_SUBSCRIBERS};
use crate::common::{CpuMeter, IDLE_LIMIT, Mode, Res, Stats, mono_ns, pace, ready};

fn node(namespace: &Namespace) -> Res<Node<ipc::Service>> {
    let mut config = Config::default();
    config.global.prefix = FileName::new(format!("bench-raw.{namespace}.").as_bytes())?;
    Ok(NodeBuilder::new()
        .config(&config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()?)
}

type Services = (
    publish_subscribe::PortFactory<ipc::Service, [u8], ()>,
    event::PortFactory<ipc::Service>,
);

/// The same limits as the byte layer's channel, so both preallocate the same chunks.
fn services(node: &Node<ipc::Service>, len: usize) -> Res<Services> {
    let name = ServiceName::new(&format!("raw/{len}"))?;
    let data = node
        .service_builder(&name)
        .publish_subscribe::<[u8]>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(BUFFER)
        .subscriber_max_borrowed_samples(MAX_HELD)
        .max_subscribers(MAX_SUBSCRIBERS)
        .max_publishers(MAX_PUBLISHERS)
        .history_size(0)
        .open_or_create()?;
    let events = node.service_builder(&name).event().open_or_create()?;
    Ok((data, events))
}

fn stamp(bytes: &[u8]) -> u64 {
    let mut t = [0u8; 8];
    t.copy_from_slice(&bytes[..8]);
    u64::from_le_bytes(t)
}

/// The receiving end of the baseline, as an application would write it by hand.
pub struct RawReceiver {
    // The ports before the node that owns them.
    listener: iceoryx2::port::listener::Listener<ipc::Service>,
    sub: iceoryx2::port::subscriber::Subscriber<ipc::Service, [u8], ()>,
    _node: Node<ipc::Service>,
    mode: Mode,
}

impl RawReceiver {
    /// Subscribes to the baseline's channel of `len`-byte samples, waiting in `mode` (event
    /// or busy polling only).
    pub fn open(namespace: &Namespace, mode: Mode, len: usize) -> Res<Self> {
        let node = node(namespace)?;
        let (data, events) = services(&node, len)?;
        Ok(Self {
            listener: events.listener_builder().create()?,
            sub: data.subscriber_builder().buffer_size(BUFFER).create()?,
            _node: node,
            mode,
        })
    }

    /// The send time stamped in the next sample, once it is in hand; `None` after
    /// [`IDLE_LIMIT`] without one.
    pub fn next(&self) -> Res<Option<u64>> {
        let deadline = Instant::now() + IDLE_LIMIT;
        let mut spins: u32 = 0;
        loop {
            if let Some(sample) = self.sub.receive()? {
                return Ok(Some(stamp(sample.payload())));
            }
            if self.mode == Mode::Event {
                self.listener.timed_wait(|_| {}, IDLE_LIMIT)?;
            } else {
                std::hint::spin_loop();
            }
            spins = spins.wrapping_add(1);
            // An event wait is long enough to read the clock after each one.
            let check = self.mode == Mode::Event || spins.is_multiple_of(64);
            if check && Instant::now() >= deadline {
                return Ok(None);
            }
        }
    }
}

/// Receives `count` samples of `len` bytes in `mode` (event or busy polling only).
pub fn receive(namespace: &Namespace, mode: Mode, len: usize, count: usize) -> Res<Stats> {
    let receiver = RawReceiver::open(namespace, mode, len)?;
    ready()?;
    let mut latencies_ns = Vec::with_capacity(count);
    let meter = CpuMeter::start();
    while latencies_ns.len() < count {
        let Some(sent) = receiver.next()? else {
            break;
        };
        latencies_ns.push(mono_ns().saturating_sub(sent));
    }
    Ok(meter.stop(latencies_ns))
}

/// How the raw publisher writes a payload into its loan.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub enum Fill {
    /// A constant byte: a memset, the least a publisher can do.
    Pattern,
    /// A copy of a message the publisher holds in its own memory (as a typed publisher
    /// encodes its message into the loan).
    CopyIn,
}

/// The sending end of the baseline, as an application would write it by hand: loan, fill
/// as [`Fill`] says, stamp, send, and notify in event mode.
pub struct RawPublisher {
    // The ports before the node that owns them.
    notifier: iceoryx2::port::notifier::Notifier<ipc::Service>,
    publisher: iceoryx2::port::publisher::Publisher<ipc::Service, [u8], ()>,
    _node: Node<ipc::Service>,
    mode: Mode,
    fill: Fill,
    message: Vec<u8>,
}

impl RawPublisher {
    /// Publishes `message` (its first 8 bytes replaced by the send time) on the
    /// baseline's channel of its length.
    pub fn open(namespace: &Namespace, mode: Mode, fill: Fill, message: Vec<u8>) -> Res<Self> {
        let node = node(namespace)?;
        let (data, events) = services(&node, message.len())?;
        Ok(Self {
            notifier: events.notifier_builder().create()?,
            publisher: data
                .publisher_builder()
                .initial_max_slice_len(message.len())
                .allocation_strategy(AllocationStrategy::PowerOfTwo)
                .create()?,
            _node: node,
            mode,
            fill,
            message,
        })
    }

    /// Publishes one sample stamped with `t0`, the time the publication started.
    pub fn send(&self, t0: u64) -> Res<()> {
        let sample = self.publisher.loan_slice_uninit(self.message.len())?;
        let mut sample = match self.fill {
            Fill::Pattern => {
                let mut sample = sample;
                sample.payload_mut().fill(MaybeUninit::new(0x5a));
                // SAFETY: every byte was written just above.
                unsafe { sample.assume_init() }
            }
            Fill::CopyIn => sample.write_from_slice(&self.message),
        };
        sample.payload_mut()[..8].copy_from_slice(&t0.to_le_bytes());
        sample.send()?;
        if self.mode == Mode::Event {
            self.notifier.notify()?;
        }
        Ok(())
    }
}

/// Publishes `count` samples of `len` bytes, each filled as `fill` says and stamped with
/// the send time. Returns the time of each send.
pub fn publish(
    namespace: &Namespace,
    mode: Mode,
    fill: Fill,
    len: usize,
    count: usize,
) -> Res<Vec<u64>> {
    let publisher = RawPublisher::open(namespace, mode, fill, vec![0x5a_u8; len])?;
    let mut sends = Vec::with_capacity(count);
    let mut next = Instant::now();
    for _ in 0..count {
        let t0 = mono_ns();
        publisher.send(t0)?;
        sends.push(mono_ns().saturating_sub(t0));
        pace(&mut next);
    }
    Ok(sends)
}
