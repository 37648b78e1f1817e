//! What one publication costs the publisher, warm, in one process: raw iceoryx2 (loan,
//! write, send), our byte layer with the IPC benchmark's channel settings and with a data
//! channel's (`names::data_config`: 32 subscribers, history 1, the recorder's deep buffer),
//! and `Context::publish` of a `RangeFinder` (header stamp, size checks, CDR encode) on a
//! data channel. Each iteration also takes the sample at a subscriber, so that every row
//! recycles its chunks the same way. The 156-byte message is the smallest scan, the
//! "64 B" row of `ipc_latency`: that benchmark measures across processes, with the caches a
//! publisher that sleeps between messages has; this one isolates the code's own cost.
//!
//! Run: `cargo bench -p lewis-runtime --bench publish_cost`.

#![allow(
    clippy::unwrap_used,
    reason = "a benchmark fails loudly on a broken setup"
)]

use std::hint::black_box;

use criterion::{Criterion, criterion_group, criterion_main};
use iceoryx2::config::Config;
use iceoryx2::prelude::{
    AllocationStrategy, FileName, NodeBuilder, SemanticString, ServiceName, SignalHandlingMode, ipc,
};
use lewis_interfaces::msg::RangeFinder;
use lewis_runtime::ipc::{ChannelConfig, Ipc, Namespace, Publisher, Subscriber};
use lewis_service::Health;
use lewis_service::{Backend, CallFailure, CallId, ContextError, ContextState, Level};

const LEN: usize = 156;

/// The IPC benchmark's settings for its byte layer and raw rows.
fn bench_config() -> ChannelConfig {
    ChannelConfig {
        buffer: 8,
        history: 0,
        max_held: 2,
        max_subscribers: 8,
        max_publishers: 2,
        ..ChannelConfig::sensor(LEN)
    }
}

/// A backend whose only channel is one data channel, as the live harness's.
struct OneChannel {
    publisher: Publisher,
}

impl Backend for OneChannel {
    fn now_ns(&self) -> i64 {
        42
    }
    fn publish(
        &mut self,
        interface: &str,
        len_bytes: usize,
        encode: &mut dyn FnMut(&mut [u8]),
    ) -> Result<(), ContextError> {
        self.publisher
            .publish_with(len_bytes, |buf| encode(buf))
            .map(|_| ())
            .map_err(|e| ContextError::Publish {
                interface: interface.to_owned(),
                reason: e.to_string(),
            })
    }
    fn call(
        &mut self,
        _call: CallId,
        interface: &str,
        _command: &'static str,
        _frame: &[u8],
        _timeout_ns: i64,
    ) -> Result<(), CallFailure> {
        Err(CallFailure::NotRequired {
            interface: interface.to_owned(),
        })
    }
    fn health_changed(&mut self, _health: &Health) {}
    fn log(&mut self, _service: &str, _level: Level, _text: &str) {}
}

fn take(subscriber: &mut Subscriber) {
    black_box(subscriber.receive().unwrap().unwrap().bytes()[0]);
}

fn publication(c: &mut Criterion) {
    let namespace = Namespace::unique("publish-cost");
    let ipc = Ipc::open(&namespace, "bench").unwrap();
    let mut group = c.benchmark_group("publish_156_bytes_warm");

    let mut config = Config::default();
    config.global.prefix = FileName::new(format!("bench-raw.{namespace}.").as_bytes()).unwrap();
    let node = NodeBuilder::new()
        .config(&config)
        .signal_handling_mode(SignalHandlingMode::Disabled)
        .create::<ipc::Service>()
        .unwrap();
    let raw = node
        .service_builder(&ServiceName::new("raw").unwrap())
        .publish_subscribe::<[u8]>()
        .enable_safe_overflow(true)
        .subscriber_max_buffer_size(8)
        .subscriber_max_borrowed_samples(2)
        .max_subscribers(8)
        .max_publishers(2)
        .history_size(0)
        .open_or_create()
        .unwrap();
    let raw_publisher = raw
        .publisher_builder()
        .initial_max_slice_len(LEN)
        .allocation_strategy(AllocationStrategy::PowerOfTwo)
        .create()
        .unwrap();
    let raw_subscriber = raw.subscriber_builder().buffer_size(8).create().unwrap();
    group.bench_function("raw iceoryx2 (loan, memset, send)", |b| {
        b.iter(|| {
            let mut sample = raw_publisher.loan_slice_uninit(LEN).unwrap();
            sample.payload_mut().fill(std::mem::MaybeUninit::new(0x5a));
            // SAFETY: every byte was written just above.
            let sample = unsafe { sample.assume_init() };
            sample.send().unwrap();
            black_box(raw_subscriber.receive().unwrap().unwrap().payload()[0]);
        });
    });

    for (label, config) in [
        ("byte layer, benchmark settings", bench_config()),
        (
            "byte layer, data channel settings",
            lewis_runtime::names::data_config("RangeFinder"),
        ),
    ] {
        let channel = format!("bytes/{label}");
        let mut publisher = ipc.publisher(&channel, &config).unwrap();
        let mut subscriber = ipc.subscriber(&channel, &config).unwrap();
        group.bench_function(label, |b| {
            b.iter(|| {
                publisher.publish_with(LEN, |buf| buf.fill(0x5a)).unwrap();
                take(&mut subscriber);
            });
        });
    }

    let config = lewis_runtime::names::data_config("RangeFinder");
    let mut backend = OneChannel {
        publisher: ipc.publisher("typed", &config).unwrap(),
    };
    let mut subscriber = ipc.subscriber("typed", &config).unwrap();
    let mut state = ContextState::new("src", 1);
    let mut scan = RangeFinder::default();
    scan.header.provider = "src".to_owned();
    assert_eq!(lewis_interfaces::cdr::encoded_len(&scan), LEN);
    group.bench_function("Context::publish, data channel settings", |b| {
        b.iter(|| {
            state.context(&mut backend).publish(&mut scan).unwrap();
            take(&mut subscriber);
        });
    });
    group.finish();
}

criterion_group!(benches, publication);
criterion_main!(benches);
