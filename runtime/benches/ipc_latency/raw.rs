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

/// Receives `count` samples of `len` bytes in `mode` (event or busy polling only).
pub fn receive(namespace: &Namespace, mode: Mode, len: usize, count: usize) -> Res<Stats> {
    let node = node(namespace)?;
    let (data, events) = services(&node, len)?;
    let listener = events.listener_builder().create()?;
    let sub = data.subscriber_builder().buffer_size(BUFFER).create()?;
    ready()?;
    let mut latencies_ns = Vec::with_capacity(count);
    let meter = CpuMeter::start();
    let mut idle_since = Instant::now();
    while latencies_ns.len() < count {
        let mut got = false;
        while let Some(sample) = sub.receive()? {
            let t1 = mono_ns();
            latencies_ns.push(t1.saturating_sub(stamp(sample.payload())));
            got = true;
        }
        if got {
            idle_since = Instant::now();
        } else if idle_since.elapsed() > IDLE_LIMIT {
            break;
        }
        if mode == Mode::Event {
            listener.timed_wait(|_| {}, IDLE_LIMIT)?;
        } else {
            std::hint::spin_loop();
        }
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

/// Publishes `count` samples of `len` bytes, each filled as `fill` says and stamped with
/// the send time; notifies the listeners only in event mode. Returns the time of each send.
pub fn publish(
    namespace: &Namespace,
    mode: Mode,
    fill: Fill,
    len: usize,
    count: usize,
) -> Res<Vec<u64>> {
    let node = node(namespace)?;
    let (data, events) = services(&node, len)?;
    let notifier = events.notifier_builder().create()?;
    let publisher = data
        .publisher_builder()
        .initial_max_slice_len(len)
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()?;
    let message = vec![0x5a_u8; len];
    let mut sends = Vec::with_capacity(count);
    let mut next = Instant::now();
    for _ in 0..count {
        let t0 = mono_ns();
        let sample = publisher.loan_slice_uninit(len)?;
        let mut sample = match fill {
            Fill::Pattern => {
                let mut sample = sample;
                sample.payload_mut().fill(MaybeUninit::new(0x5a));
                // SAFETY: every byte was written just above.
                unsafe { sample.assume_init() }
            }
            Fill::CopyIn => sample.write_from_slice(&message),
        };
        sample.payload_mut()[..8].copy_from_slice(&t0.to_le_bytes());
        sample.send()?;
        if mode == Mode::Event {
            notifier.notify()?;
        }
        sends.push(mono_ns().saturating_sub(t0));
        pace(&mut next);
    }
    Ok(sends)
}
