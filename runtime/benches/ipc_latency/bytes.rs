//! Our byte layer: `ipc::Publisher` and `ipc::Subscriber` with a `WaitSet`, no CDR.

use std::time::Instant;

use lewis_runtime::ipc::{ChannelConfig, Ipc, Namespace, WaitSet, Woken};

use crate::common::{CpuMeter, IDLE_LIMIT, Mode, Res, Stats, mono_ns, pace, ready};

// The same channel settings as the raw baseline, so both preallocate the same number of
// chunks (same memory, same page-fault pattern).
use lewis_runtime::ipc::baseline::{BUFFER, MAX_HELD, MAX_PUBLISHERS, MAX_SUBSCRIBERS};

fn channel(len: usize) -> (String, ChannelConfig) {
    let config = ChannelConfig {
        buffer: BUFFER,
        history: 0,
        max_held: MAX_HELD,
        max_subscribers: MAX_SUBSCRIBERS,
        max_publishers: MAX_PUBLISHERS,
        ..ChannelConfig::sensor(len)
    };
    (format!("bench/{len}"), config)
}

fn stamp(bytes: &[u8]) -> u64 {
    let mut t = [0u8; 8];
    t.copy_from_slice(&bytes[..8]);
    u64::from_le_bytes(t)
}

/// Receives `count` samples of `len` bytes, waiting in `mode`.
pub fn receive(namespace: &Namespace, mode: Mode, len: usize, count: usize) -> Res<Stats> {
    let ipc = Ipc::open(namespace, "bench-receiver")?;
    let (name, config) = channel(len);
    let mut sub = ipc.subscriber(&name, &config)?;
    let waits = WaitSet::new(mode.wake_mode());
    ready()?;
    let mut latencies_ns = Vec::with_capacity(count);
    let meter = CpuMeter::start();
    while latencies_ns.len() < count {
        match waits.wait(&[&sub], Some(Instant::now() + IDLE_LIMIT))? {
            Woken::DeadlineReached => break,
            Woken::Ready(_) | Woken::Interrupted => {}
        }
        while let Some(sample) = sub.receive()? {
            let t1 = mono_ns();
            latencies_ns.push(t1.saturating_sub(stamp(&sample)));
        }
    }
    Ok(meter.stop(latencies_ns))
}

/// Publishes `count` samples of `len` bytes, each filled and stamped with the send time.
/// Our publisher always notifies (it does not know how its subscribers wait). Returns the
/// time of each publish call.
pub fn publish(namespace: &Namespace, len: usize, count: usize) -> Res<Vec<u64>> {
    let ipc = Ipc::open(namespace, "bench-publisher")?;
    let (name, config) = channel(len);
    let mut publisher = ipc.publisher(&name, &config)?;
    let mut sends = Vec::with_capacity(count);
    let mut next = Instant::now();
    for _ in 0..count {
        let t0 = mono_ns();
        publisher.publish_with(len, |buf| {
            buf.fill(0x5a);
            buf[..8].copy_from_slice(&t0.to_le_bytes());
        })?;
        sends.push(mono_ns().saturating_sub(t0));
        pace(&mut next);
    }
    Ok(sends)
}
