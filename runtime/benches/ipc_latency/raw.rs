//! The baseline: raw iceoryx2 publish-subscribe of a byte slice, with an iceoryx2 event
//! service for the wake-ups, as an application would write it by hand
//! (`lewis_runtime::ipc::baseline`, which the reflex benchmark shares), driven at the pace
//! of this benchmark.

use std::time::Instant;

use lewis_runtime::ipc::Namespace;
use lewis_runtime::ipc::baseline::Wake;
pub use lewis_runtime::ipc::baseline::{Fill, RawPublisher, RawReceiver};

use crate::common::{CpuMeter, IDLE_LIMIT, Mode, Res, Stats, mono_ns, pace, ready};

/// The baseline's wake-up for a mode of the benchmark (event or busy polling only).
pub fn wake(mode: Mode) -> Res<Wake> {
    match mode {
        Mode::Event => Ok(Wake::Event),
        Mode::BusyPoll => Ok(Wake::BusyPoll),
        other => {
            Err(format!("the raw baseline waits on events or busy polls, not {other:?}").into())
        }
    }
}

/// Receives `count` samples of `len` bytes in `mode` (event or busy polling only).
pub fn receive(namespace: &Namespace, mode: Mode, len: usize, count: usize) -> Res<Stats> {
    let receiver = RawReceiver::open(namespace, wake(mode)?, len)?;
    ready()?;
    let mut latencies_ns = Vec::with_capacity(count);
    let meter = CpuMeter::start();
    while latencies_ns.len() < count {
        let Some(sent) = receiver.next(IDLE_LIMIT)? else {
            break;
        };
        latencies_ns.push(mono_ns().saturating_sub(sent));
    }
    Ok(meter.stop(latencies_ns))
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
    let publisher = RawPublisher::open(namespace, wake(mode)?, fill, vec![0x5a_u8; len])?;
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
