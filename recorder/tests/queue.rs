//! The tap and the writer thread: the tap never waits; a full queue drops and counts; the
//! losses the recorder counts equal the gaps in the file exactly.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use std::collections::BTreeMap;
use std::sync::mpsc;

use common::traffic::{self, Msg};
use common::{Digests, options, python_read, sample};
use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Header, RangeFinder};
use lewis_recorder::companion::CompanionOptions;
use lewis_recorder::{ChannelSpec, Compression, Dropped, QueueOptions, Recorder, SECOND_NS, spawn};
use lewis_testkit::doctor;

#[test]
fn the_stress_mix_through_the_queue_loses_nothing_and_keeps_every_sequence_number() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("stress.mcap");
    let mut options = options(&path);
    options.compression = Compression::Lz4;
    let recorder = Recorder::create(options).unwrap();
    // Three seconds of the mix fed as fast as possible: a queue that holds them all.
    let queue = QueueOptions {
        capacity_messages: 70_000,
        capacity_bytes: 128 * 1024 * 1024,
        ..QueueOptions::default()
    };
    let (tap, writer) = spawn(recorder, queue, || 0).unwrap();
    let channels = traffic::stress_channels();
    let ids: Vec<_> = channels.iter().map(|c| tap.register(c.clone())).collect();
    let mut digests = Digests::default();
    for m in traffic::stress_mix(3 * SECOND_NS) {
        tap.try_record(&sample(ids[m.channel], &m)).unwrap();
        digests.add(&channels[m.channel].topic, m.seq, &m.data);
    }
    assert_eq!(tap.dropped_total(), 0);
    let report = writer.finish().unwrap();
    assert_eq!(report.lost(), 0);
    assert_eq!(report.messages(), 20 * 3000 + 90);

    doctor(&path);
    let view = python_read(&[path]);
    let got = view.digests();
    for (topic, digest) in &got {
        let last = if topic == "/camera/ImageSource" {
            90
        } else {
            3000
        };
        assert_eq!(
            digest.seq_runs,
            [[1, last]],
            "{topic}: missing sequence numbers"
        );
    }
    assert_eq!(got, digests.finish());
    assert!(view.loss(0).values().all(|&lost| lost == 0));
}

/// A clock for the writer thread that holds it, when asked, until released: a writer
/// slowed deterministically. It says when the writer is held.
struct Gate {
    held: mpsc::Receiver<()>,
    release: mpsc::SyncSender<()>,
}

fn gated_clock() -> (Gate, impl FnMut() -> i64 + Send + 'static) {
    let (held_tx, held) = mpsc::channel();
    let (release, release_rx) = mpsc::sync_channel::<()>(0);
    let clock = move || {
        // Once the test has gone, the writer is no longer held.
        if held_tx.send(()).is_ok() {
            let _ = release_rx.recv();
        }
        0
    };
    (Gate { held, release }, clock)
}

#[test]
fn with_a_held_writer_the_tap_drops_and_counts_and_the_losses_equal_the_gaps() {
    const CAPACITY: usize = 100;
    const CHANNELS: usize = 20;
    const BURST_PER_CHANNEL: u64 = 25;
    const BURSTS: u64 = 3;
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("slow.mcap");
    let recorder = Recorder::create(options(&path)).unwrap();
    let queue = QueueOptions {
        capacity_messages: CAPACITY,
        capacity_bytes: 64 * 1024 * 1024,
        ..QueueOptions::default()
    };
    let (gate, clock) = gated_clock();
    let (tap, writer) = spawn(recorder, queue, clock).unwrap();
    let channels = &traffic::stress_channels()[..CHANNELS];
    let ids: Vec<_> = channels.iter().map(|c| tap.register(c.clone())).collect();
    let mut digests = Digests::default();
    let mut offered = 0_u64;
    let mut dropped = 0_u64;
    let mut seq = 0_u64;
    let mut offer = |seq: u64, channel: usize, digests: &mut Digests| {
        let time = seq as i64 * 1_000_000 + channel as i64 * 1000;
        let m = Msg {
            channel,
            seq,
            publish_time_ns: time,
            log_time_ns: time,
            data: traffic::small_message(channel, seq, time),
        };
        let result = tap.try_record(&sample(ids[channel], &m));
        offered += 1;
        match result {
            Ok(()) => digests.add(&channels[channel].topic, seq, &m.data),
            Err(reason) => {
                assert_eq!(reason, Dropped::QueueFull);
                dropped += 1;
            }
        }
    };
    for _ in 0..BURSTS {
        // The writer is idle and held: the queue takes CAPACITY messages, then drops.
        gate.held.recv().unwrap();
        for _ in 0..BURST_PER_CHANNEL {
            seq += 1;
            for channel in 0..CHANNELS {
                offer(seq, channel, &mut digests);
            }
        }
        gate.release.send(()).unwrap();
    }
    // A last message per channel once the writer is idle again: it shows every gap.
    gate.held.recv().unwrap();
    seq += 1;
    for channel in 0..CHANNELS {
        offer(seq, channel, &mut digests);
    }
    drop(gate);

    let per_burst_dropped = BURST_PER_CHANNEL * CHANNELS as u64 - CAPACITY as u64;
    assert_eq!(dropped, BURSTS * per_burst_dropped);
    assert_eq!(
        offered,
        BURSTS * BURST_PER_CHANNEL * CHANNELS as u64 + CHANNELS as u64
    );
    assert_eq!(tap.dropped_total(), dropped);
    let tap_dropped: BTreeMap<String, u64> = channels
        .iter()
        .zip(&ids)
        .map(|(c, &id)| (c.topic.clone(), tap.dropped(id)))
        .collect();
    let report = writer.finish().unwrap();

    doctor(&path);
    let view = python_read(&[path]);
    let got = view.digests();
    assert_eq!(got, digests.finish());
    let gaps: BTreeMap<String, u64> = got
        .iter()
        .map(|(topic, d)| {
            let span = d.seq_runs.last().unwrap()[1] - d.seq_runs[0][0] + 1;
            (topic.clone(), span - d.count)
        })
        .collect();
    assert_eq!(gaps.values().sum::<u64>(), dropped);
    assert_eq!(
        gaps, tap_dropped,
        "every drop at the tap is a gap in the file"
    );
    assert_eq!(view.loss(0), gaps, "lewis.loss counts the gaps");
    let counted: BTreeMap<String, u64> = report
        .counts
        .iter()
        .map(|(topic, c)| (topic.clone(), c.lost))
        .collect();
    assert_eq!(counted, gaps);
    let recorder_dropped: BTreeMap<String, u64> = report
        .counts
        .iter()
        .map(|(topic, c)| (topic.clone(), c.dropped))
        .collect();
    assert_eq!(recorder_dropped, tap_dropped);
    for (topic, (_, lost, dropped)) in view.last_stats() {
        assert_eq!(lost as u64, gaps[&topic], "{topic}: stats message");
        assert_eq!(
            dropped as u64, tap_dropped[&topic],
            "{topic}: stats message"
        );
    }
}

#[test]
fn after_the_writer_finished_the_tap_drops_with_stopped() {
    let dir = tempfile::tempdir().unwrap();
    let recorder = Recorder::create(options(&dir.path().join("r.mcap"))).unwrap();
    let (tap, writer) = spawn(recorder, QueueOptions::default(), || 0).unwrap();
    let channels = traffic::stress_channels();
    let id = tap.register(channels[0].clone());
    writer.finish().unwrap();
    let m = Msg {
        channel: 0,
        seq: 1,
        publish_time_ns: 0,
        log_time_ns: 0,
        data: traffic::small_message(0, 1, 0),
    };
    assert_eq!(tap.try_record(&sample(id, &m)), Err(Dropped::Stopped));
    assert_eq!(tap.dropped(id), 1);
}

#[test]
fn a_channel_registered_at_the_tap_appears_in_the_file_before_its_first_message() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("r.mcap");
    let recorder = Recorder::create(options(&path)).unwrap();
    let (tap, writer) = spawn(recorder, QueueOptions::default(), || 0).unwrap();
    let _silent = tap.register(traffic::stress_channels()[3].clone());
    writer.finish().unwrap();
    let view = python_read(&[path]);
    assert!(view.file(0)["channels"]["/sensor03/Distance"].is_object());
}

#[test]
fn batches_hand_over_every_message_in_order_within_the_same_bounds() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("batched.mcap");
    let recorder = Recorder::create(options(&path)).unwrap();
    // Room for 1000 messages: a held writer takes exactly that many, batched or not.
    let queue = QueueOptions {
        capacity_messages: 1000,
        capacity_bytes: 64 * 1024 * 1024,
        ..QueueOptions::default()
    };
    let (gate, clock) = gated_clock();
    let (tap, writer) = spawn(recorder, queue, clock).unwrap();
    let channels = traffic::stress_channels();
    let ids: Vec<_> = channels.iter().map(|c| tap.register(c.clone())).collect();
    let mut digests = Digests::default();
    gate.held.recv().unwrap();
    let mut batch = tap.batch();
    let mut taken = 0;
    // One second of the mix (20,030 messages, the camera's frames among them) offered in
    // one go to a writer that is held: batches fill, hand over, and the bound holds.
    for m in traffic::stress_mix(SECOND_NS) {
        match batch.record(&sample(ids[m.channel], &m)) {
            Ok(()) => {
                taken += 1;
                digests.add(&channels[m.channel].topic, m.seq, &m.data);
            }
            Err(reason) => assert_eq!(reason, Dropped::QueueFull),
        }
    }
    batch.flush().unwrap();
    assert_eq!(taken, 1000);
    assert_eq!(batch.dropped(), 20 * 1000 + 30 - 1000);
    assert_eq!(tap.dropped_total(), batch.dropped());
    drop(batch);
    drop(gate);
    let report = writer.finish().unwrap();
    assert_eq!(report.messages(), 1000);
    let view = python_read(&[path]);
    assert_eq!(view.digests(), digests.finish());
}

#[test]
fn a_batch_handed_to_a_stopped_writer_is_dropped_and_counted_whole() {
    let dir = tempfile::tempdir().unwrap();
    let recorder = Recorder::create(options(&dir.path().join("r.mcap"))).unwrap();
    let (tap, writer) = spawn(recorder, QueueOptions::default(), || 0).unwrap();
    let id = tap.register(traffic::stress_channels()[0].clone());
    let mut batch = tap.batch();
    for seq in 1..=10 {
        let m = Msg {
            channel: 0,
            seq,
            publish_time_ns: 0,
            log_time_ns: 0,
            data: traffic::small_message(0, seq, 0),
        };
        batch.record(&sample(id, &m)).unwrap();
    }
    writer.finish().unwrap();
    assert_eq!(batch.flush(), Err(Dropped::Stopped));
    assert_eq!((batch.dropped(), tap.dropped(id)), (10, 10));
}

#[test]
fn a_channel_registered_after_the_recorder_added_companions_keeps_its_own_messages() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("grown.mcap");
    let mut options = options(&path);
    options.companions = Some(CompanionOptions::default());
    let recorder = Recorder::create(options).unwrap();
    let (gate, clock) = gated_clock();
    let (tap, writer) = spawn(recorder, QueueOptions::default(), clock).unwrap();
    let range_finder = lewis_interfaces::interface_info("RangeFinder").unwrap();
    let scan = |seq: u64| {
        cdr::to_vec(&RangeFinder {
            header: Header {
                provider: "laser".to_owned(),
                seq,
                publish_time_ns: 0,
                inputs: Vec::new(),
            },
            ranges: vec![1.0, 2.5],
            range_count: 2,
            max_range: 8.0,
            uniform: true,
            theta_separation: 0.5,
            ..RangeFinder::default()
        })
    };
    let laser = tap.register(ChannelSpec::publication(
        range_finder,
        "laser",
        "/laser/RangeFinder",
    ));
    let first = Msg {
        channel: 0,
        seq: 1,
        publish_time_ns: 0,
        log_time_ns: 0,
        data: scan(1),
    };
    tap.try_record(&sample(laser, &first)).unwrap();
    // Idle twice: whether or not the scan was queued at the first, it is written by the
    // second, and with it its companions (its frame and /laser/scan).
    gate.held.recv().unwrap();
    gate.release.send(()).unwrap();
    gate.held.recv().unwrap();
    let sonar = tap.register(ChannelSpec::publication(
        range_finder,
        "sonar",
        "/sonar/RangeFinder",
    ));
    gate.release.send(()).unwrap();
    tap.try_record(&sample(sonar, &first)).unwrap();
    drop(gate);
    writer.finish().unwrap();

    let bytes = std::fs::read(&path).unwrap();
    let mut topics: BTreeMap<String, usize> = BTreeMap::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        *topics
            .entry(message.unwrap().channel.topic.clone())
            .or_default() += 1;
    }
    assert_eq!(topics.get("/laser/RangeFinder"), Some(&1), "{topics:?}");
    assert_eq!(topics.get("/sonar/RangeFinder"), Some(&1), "{topics:?}");
    assert_eq!(topics.get("/laser/scan"), Some(&1), "{topics:?}");
}
