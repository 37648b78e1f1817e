//! IPC behaviour that one process can show: channels, overflow policies, history,
//! namespaces, commands and the wait set. Each test has its own namespace, so they run in
//! parallel; waits have long deadlines that only act as watchdogs.

#![allow(
    clippy::unwrap_used,
    reason = "helpers shared by the tests: a failure there is a test failure"
)]

use std::time::{Duration, Instant};

use lewis_runtime::ipc::{
    CallError, ChannelConfig, CommandConfig, Ipc, Namespace, NodeLiveness, OverflowPolicy,
    Published, Subscriber, WaitSet, Waitable, WakeMode, Woken,
};

const WATCHDOG: Duration = Duration::from_secs(20);

fn open(tag: &str) -> Ipc {
    Ipc::open(&Namespace::unique(tag), "test").unwrap()
}

/// Receives everything unread as (seq, first byte) pairs.
fn drain(sub: &mut Subscriber) -> Vec<(u64, u8)> {
    sub.drain()
        .map(|r| {
            let r = r.unwrap();
            (r.seq(), r.bytes()[0])
        })
        .collect()
}

fn wait_ready(waits: &WaitSet, sources: &[&dyn Waitable]) -> Vec<usize> {
    match waits
        .wait(sources, Some(Instant::now() + WATCHDOG))
        .unwrap()
    {
        Woken::Ready(fired) => fired.iter().collect(),
        other => panic!("watchdog: nothing became ready within {WATCHDOG:?}: {other:?}"),
    }
}

fn small(overflow: OverflowPolicy) -> ChannelConfig {
    ChannelConfig {
        buffer: 2,
        overflow,
        history: 0,
        ..ChannelConfig::sensor(64)
    }
}

/// Publishes `0`, takes it (the loss baseline), publishes `1..=5` with nobody reading, then
/// `6` after a read. Returns what was read after the burst, the subscriber's loss count
/// and the publisher's discard count.
fn overflow_run(overflow: OverflowPolicy) -> (Vec<(u64, u8)>, u64, u64) {
    let ipc = open("overflow");
    let config = small(overflow);
    let mut sub = ipc.subscriber("burst", &config).unwrap();
    let mut publisher = ipc.publisher("burst", &config).unwrap();
    publisher.publish(&[0]).unwrap();
    assert_eq!(drain(&mut sub), vec![(0, 0)]);
    for i in 1..=5u8 {
        publisher.publish(&[i]).unwrap();
    }
    let mut read = drain(&mut sub);
    publisher.publish(&[6]).unwrap();
    read.extend(drain(&mut sub));
    (read, sub.lost(), publisher.discarded())
}

#[test]
fn drop_oldest_keeps_the_newest_and_the_subscriber_counts_the_loss() {
    assert_eq!(
        overflow_run(OverflowPolicy::DropOldest),
        (vec![(4, 4), (5, 5), (6, 6)], 3, 0)
    );
}

#[test]
fn drop_newest_keeps_the_oldest_and_both_sides_count_the_loss() {
    assert_eq!(
        overflow_run(OverflowPolicy::DropNewest),
        (vec![(1, 1), (2, 2), (6, 6)], 3, 3)
    );
}

#[test]
fn block_gives_up_after_its_bound_on_a_reader_that_never_reads_and_counts_it() {
    let policy = OverflowPolicy::Block {
        max_wait: Duration::from_millis(1),
    };
    assert_eq!(overflow_run(policy), (vec![(1, 1), (2, 2), (6, 6)], 3, 3));
}

#[test]
fn block_loses_nothing_with_a_slow_reader_in_another_thread() {
    let ipc = open("block-thread");
    let config = small(OverflowPolicy::Block {
        max_wait: Duration::from_secs(60),
    });
    let mut publisher = ipc.publisher("slow", &config).unwrap();
    let namespace = ipc.namespace().clone();
    let (ready_tx, ready_rx) = std::sync::mpsc::channel();
    let reader = std::thread::spawn(move || {
        let ipc = Ipc::open(&namespace, "reader").unwrap();
        let mut sub = ipc.subscriber("slow", &config).unwrap();
        ready_tx.send(()).unwrap();
        let waits = WaitSet::new(WakeMode::Event);
        let mut seen = Vec::new();
        while seen.len() < 100 {
            wait_ready(&waits, &[&sub]);
            seen.extend(drain(&mut sub).into_iter().map(|(seq, _)| seq));
        }
        (seen, sub.lost())
    });
    ready_rx.recv().unwrap();
    for i in 0..100u8 {
        publisher.publish(&[i]).unwrap();
    }
    let (seen, lost) = reader.join().unwrap();
    assert_eq!(seen, (0..100).collect::<Vec<u64>>());
    assert_eq!((lost, publisher.discarded()), (0, 0));
}

#[test]
fn latest_returns_the_newest_sample_and_skipping_is_not_a_loss() {
    let ipc = open("latest");
    let config = ChannelConfig {
        buffer: 8,
        ..ChannelConfig::sensor(16)
    };
    let mut sub = ipc.subscriber("pose", &config).unwrap();
    let mut publisher = ipc.publisher("pose", &config).unwrap();
    for i in 0..5u8 {
        publisher.publish(&[i]).unwrap();
    }
    let latest = sub.latest().unwrap().unwrap();
    assert_eq!((latest.seq(), latest.bytes()), (4, &[4u8][..]));
    drop(latest);
    assert!(sub.latest().unwrap().is_none());
    assert_eq!(sub.lost(), 0);
}

#[test]
fn holding_more_samples_than_allowed_is_an_error_not_a_panic() {
    let ipc = open("held");
    let config = ChannelConfig {
        buffer: 8,
        max_held: 2,
        ..ChannelConfig::sensor(16)
    };
    let mut sub = ipc.subscriber("held", &config).unwrap();
    let mut publisher = ipc.publisher("held", &config).unwrap();
    for i in 0..3u8 {
        publisher.publish(&[i]).unwrap();
    }
    let first = sub.receive().unwrap();
    let second = sub.receive().unwrap();
    assert!(first.is_some() && second.is_some());
    assert_eq!(
        sub.receive().map(|r| r.map(|r| r.seq())),
        Err(lewis_runtime::ipc::ReceiveError::TooManyHeld {
            channel: "held".into(),
            max_held: 2
        })
    );
}

#[test]
fn a_late_joiner_gets_the_history_once_the_publisher_updates_its_connections() {
    let ipc = open("history");
    let config = ChannelConfig {
        history: 2,
        ..ChannelConfig::sensor(16)
    };
    let mut publisher = ipc.publisher("status", &config).unwrap();
    for i in 0..3u8 {
        publisher.publish(&[i]).unwrap();
    }
    let mut late = ipc.subscriber("status", &config).unwrap();
    publisher.update_connections().unwrap();
    wait_ready(&WaitSet::new(WakeMode::Event), &[&late]);
    assert_eq!(drain(&mut late), vec![(1, 1), (2, 2)]);
    assert_eq!(late.lost(), 0);
}

#[test]
fn two_namespaces_share_neither_channels_nor_nodes() {
    let a = open("ns-a");
    let b = open("ns-b");
    let config = ChannelConfig::default();
    let mut sub_a = a.subscriber("scan", &config).unwrap();
    let mut sub_b = b.subscriber("scan", &config).unwrap();
    let mut pub_a = a.publisher("scan", &config).unwrap();
    assert_eq!(
        pub_a.publish(b"only a").unwrap(),
        Published {
            seq: 0,
            delivered_to: 1
        }
    );
    assert_eq!(sub_a.receive().unwrap().unwrap().bytes(), b"only a");
    assert!(sub_b.receive().unwrap().is_none());
    let ids = |ipc: &Ipc| -> Vec<u128> { ipc.nodes().unwrap().iter().map(|n| n.id).collect() };
    assert_eq!(ids(&a), vec![a.node_id()]);
    assert_eq!(ids(&b), vec![b.node_id()]);
    let me = &a.nodes().unwrap()[0];
    assert_eq!(
        (me.liveness, me.name.as_deref(), me.pid),
        (
            NodeLiveness::Alive,
            Some("test"),
            Some(std::process::id() as i32)
        )
    );
}

#[test]
fn settings_that_differ_from_the_channel_creator_are_an_error() {
    let ipc = open("mismatch");
    let _publisher = ipc
        .publisher("scan", &small(OverflowPolicy::DropOldest))
        .unwrap();
    let err = ipc
        .subscriber("scan", &small(OverflowPolicy::DropNewest))
        .unwrap_err();
    assert!(
        matches!(&err, lewis_runtime::ipc::IpcError::Service { pattern: "channel", name, .. } if name == "scan"),
        "{err}"
    );
}

#[test]
fn the_wait_set_reports_which_sources_fired_and_each_wake_mode_sees_the_data() {
    for mode in [
        WakeMode::Event,
        WakeMode::BusyPoll,
        WakeMode::Adaptive {
            spin: Duration::from_micros(50),
        },
        WakeMode::Predictive {
            margin: Duration::from_micros(50),
        },
    ] {
        let ipc = open("which");
        let config = ChannelConfig::default();
        let quiet = ipc.subscriber("quiet", &config).unwrap();
        let mut busy = ipc.subscriber("busy", &config).unwrap();
        let mut publisher = ipc.publisher("busy", &config).unwrap();
        let waits = WaitSet::new(mode);
        assert_eq!(
            waits
                .wait(
                    &[&quiet, &busy],
                    Some(Instant::now() + Duration::from_millis(2))
                )
                .unwrap(),
            Woken::DeadlineReached,
            "{mode:?}"
        );
        publisher.publish(b"x").unwrap();
        assert_eq!(wait_ready(&waits, &[&quiet, &busy]), vec![1], "{mode:?}");
        // Level-triggered: still ready until read.
        assert_eq!(wait_ready(&waits, &[&quiet, &busy]), vec![1], "{mode:?}");
        assert_eq!(drain(&mut busy), vec![(0, b'x')]);
    }
}

#[test]
fn payloads_of_every_size_arrive_intact_and_the_segment_grows_for_big_ones() {
    let ipc = open("sizes");
    let config = ChannelConfig::sensor(64);
    let mut sub = ipc.subscriber("frames", &config).unwrap();
    let mut publisher = ipc.publisher("frames", &config).unwrap();
    for len in [0, 64, 361 * 4, 64 << 10, 640 * 480 * 3, 1 << 20] {
        publisher
            .publish_with(len, |buf| {
                for (i, b) in buf.iter_mut().enumerate() {
                    *b = (i % 251) as u8;
                }
            })
            .unwrap();
        let got = sub.receive().unwrap().unwrap();
        assert_eq!(got.len(), len);
        assert!(
            got.iter().enumerate().all(|(i, b)| *b == (i % 251) as u8),
            "corrupt payload of {len} bytes"
        );
    }
}

fn command_config() -> CommandConfig {
    CommandConfig {
        max_pending: 2,
        ..CommandConfig::default()
    }
}

#[test]
fn a_command_is_answered_and_server_and_client_share_one_wait_set() {
    let ipc = open("cmd");
    let server = ipc.command_server("set_speed", &command_config()).unwrap();
    let mut client = ipc.command_client("set_speed", &command_config()).unwrap();
    let waits = WaitSet::new(WakeMode::Event);
    let call = client
        .call_with(3, Duration::from_secs(30), |b| b.copy_from_slice(b"0.5"))
        .unwrap();
    assert_eq!(wait_ready(&waits, &[&server, &client]), vec![0]);
    let request = server.receive().unwrap().unwrap();
    assert_eq!(request.bytes(), b"0.5");
    let answer = [b"ok:".as_slice(), request.bytes()].concat();
    server.reply(request, &answer).unwrap();
    assert_eq!(wait_ready(&waits, &[&server, &client]), vec![1]);
    let outcome = client.take_outcome().unwrap();
    assert_eq!(outcome.call, call);
    assert_eq!(outcome.result.unwrap().bytes(), b"ok:0.5");
    assert_eq!(client.pending(), 0);
}

#[test]
fn a_call_without_server_fails_at_once_with_no_server() {
    let ipc = open("noserver");
    let mut client = ipc.command_client("stop", &command_config()).unwrap();
    assert_eq!(
        client
            .call_blocking(0, Duration::from_secs(30), |_| {}, WakeMode::Event)
            .map(|r| r.bytes().to_vec()),
        Err(CallError::NoServer {
            command: "stop".into()
        })
    );
}

#[test]
fn a_call_to_a_server_that_never_answers_times_out_with_an_error() {
    let ipc = open("stalled");
    let _server = ipc.command_server("stop", &command_config()).unwrap();
    let mut client = ipc.command_client("stop", &command_config()).unwrap();
    let timeout = Duration::from_millis(20);
    for mode in [WakeMode::Event, WakeMode::BusyPoll] {
        assert_eq!(
            client
                .call_blocking(1, timeout, |b| b[0] = 1, mode)
                .map(|r| r.bytes().to_vec()),
            Err(CallError::Timeout {
                command: "stop".into(),
                timeout
            }),
            "{mode:?}"
        );
    }
}

#[test]
fn too_many_outstanding_calls_are_refused() {
    let ipc = open("pending");
    let _server = ipc.command_server("ping", &command_config()).unwrap();
    let mut client = ipc.command_client("ping", &command_config()).unwrap();
    for _ in 0..2 {
        client.call(b"p", Duration::from_secs(30)).unwrap();
    }
    assert_eq!(
        client.call(b"p", Duration::from_secs(30)),
        Err(CallError::TooManyPending {
            command: "ping".into(),
            max_pending: 2
        })
    );
}

#[test]
fn a_predictive_wait_receives_every_sample_of_a_periodic_stream_and_one_off_the_beat() {
    let namespace = Namespace::unique("predict");
    let ipc = Ipc::open(&namespace, "test").unwrap();
    let config = ChannelConfig {
        buffer: 64,
        ..ChannelConfig::sensor(64)
    };
    let mut sub = ipc.subscriber("beat", &config).unwrap();
    // A publisher on its own thread, every 2 ms, with one beat skipped and one sample late:
    // the wait set learns the period, and samples off the beat are still received.
    let publisher = std::thread::spawn(move || {
        let ipc = Ipc::open(&namespace, "publisher").unwrap();
        let mut publisher = ipc.publisher("beat", &config).unwrap();
        let mut next = Instant::now();
        for i in 0..40u8 {
            next += Duration::from_millis(if i == 20 { 4 } else { 2 });
            if i == 30 {
                next += Duration::from_micros(700);
            }
            std::thread::sleep(next.saturating_duration_since(Instant::now()));
            publisher.publish(&[i]).unwrap();
        }
    });
    let waits = WaitSet::new(WakeMode::Predictive {
        margin: Duration::from_micros(200),
    });
    let mut got = Vec::new();
    while got.len() < 40 {
        wait_ready(&waits, &[&sub]);
        got.extend(drain(&mut sub).into_iter().map(|(_, byte)| byte));
    }
    publisher.join().unwrap();
    assert_eq!(got, (0..40).collect::<Vec<u8>>());
    assert_eq!(sub.lost(), 0);
}

#[test]
fn a_stream_that_changes_length_now_and_then_loses_leaks_and_corrupts_nothing() {
    // A publisher keeps a spare loan of the length it published twice in a row: runs of
    // one length use it, a change of length returns it. Many more publications than the
    // channel has chunks: a spare that leaked would exhaust the pool.
    let ipc = open("spare");
    let config = ChannelConfig::sensor(64);
    let mut sub = ipc.subscriber("scans", &config).unwrap();
    let mut publisher = ipc.publisher("scans", &config).unwrap();
    let lengths = [16, 16, 16, 48, 48, 16, 0, 0, 0, 4096, 16, 16];
    for (seq, len) in (0u64..).zip(lengths.iter().cycle().take(3000)) {
        let fill = (seq % 251) as u8;
        publisher.publish_with(*len, |buf| buf.fill(fill)).unwrap();
        let got = sub.receive().unwrap().unwrap();
        assert_eq!((got.seq(), got.len()), (seq, *len));
        assert!(got.iter().all(|b| *b == fill), "sample {seq} corrupt");
    }
    assert_eq!(sub.lost(), 0);
}
