//! The files the recorder writes, read back by the independent Python readers
//! (mcap + mcap-ros2-support) and checked by `pymcap-cli doctor`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use std::collections::BTreeMap;

use common::traffic::{self, Msg};
use common::{Digests, options, python_read, sample, write_all};
use lewis_recorder::index::{PartsIndex, index_path};
use lewis_recorder::{Compression, Recorder, SECOND_NS};
use lewis_testkit::doctor;

fn zero_loss(digests: &BTreeMap<String, common::TopicDigest>) -> BTreeMap<String, u64> {
    digests.keys().map(|t| (t.clone(), 0)).collect()
}

fn check_compression(compression: Compression, chunk_name: &str) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let mut options = options(&path);
    options.compression = compression;
    let mut recorder = Recorder::create(options).unwrap();
    let channels = traffic::stress_channels();
    let written = write_all(&mut recorder, &channels, traffic::stress_mix(SECOND_NS / 2));
    let report = recorder.close().unwrap();
    assert_eq!(report.parts, std::slice::from_ref(&path));
    assert_eq!(report.lost(), 0);

    doctor(&path);
    let view = python_read(std::slice::from_ref(&path));
    assert_eq!(view.digests(), written);
    let file = view.file(0);
    assert_eq!(file["profile"], "ros2");
    assert_eq!(file["compressions"], serde_json::json!([chunk_name]));
    let camera = &file["channels"]["/camera/ImageSource"];
    assert_eq!(camera["message_encoding"], "cdr");
    assert_eq!(camera["schema_encoding"], "ros2msg");
    assert_eq!(camera["schema_name"], "lewis_interfaces/msg/ImageSource");
    assert_eq!(
        camera["metadata"],
        serde_json::json!({"provider": "camera", "interface": "ImageSource", "interface_version": "1.0"})
    );
    // MCAP's ros2 profile requires the offered QoS on every channel, as rosbag2 writes it.
    let infinite = serde_json::json!({"sec": 9_223_372_036_i64, "nsec": 854_775_807});
    for (topic, channel) in file["channels"].as_object().unwrap() {
        let latched = topic == "/tf_static";
        assert_eq!(
            channel["qos"],
            serde_json::json!([{
                "history": 1, "depth": if latched { 1 } else { 10 }, "reliability": 1,
                "durability": if latched { 1 } else { 2 }, "deadline": infinite,
                "lifespan": infinite, "liveliness": 1, "liveliness_lease_duration": infinite,
                "avoid_ros_namespace_conventions": false,
            }]),
            "{topic}"
        );
    }
    let metadata = &file["metadata"];
    assert!(
        metadata["lewis.interfaces"]["RangeFinder.xml"]
            .as_str()
            .unwrap()
            .contains("<interface name=\"RangeFinder\"")
    );
    assert!(metadata["lewis.interfaces"]["types.xml"].is_string());
    assert_eq!(
        metadata["lewis.robot"]["sim.toml"],
        "[robot]\nname = \"test\"\n"
    );
    assert_eq!(view.loss(0), zero_loss(&written));
    let stats = view.last_stats();
    assert_eq!(stats["/camera/ImageSource"], (15, 0, 0));
    assert_eq!(stats["/sensor07/Distance"], (500, 0, 0));
}

#[test]
fn a_zstd_recording_is_decoded_by_python_and_passes_doctor() {
    check_compression(Compression::Zstd, "zstd");
}

#[test]
fn an_lz4_recording_is_decoded_by_python_and_passes_doctor() {
    check_compression(Compression::Lz4, "lz4");
}

#[test]
fn an_uncompressed_recording_is_decoded_by_python_and_passes_doctor() {
    check_compression(Compression::None, "");
}

fn check_rotation(configure: impl FnOnce(&mut lewis_recorder::RecorderOptions), min_parts: usize) {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let mut options = options(&path);
    options.compression = Compression::Lz4;
    configure(&mut options);
    let mut recorder = Recorder::create(options).unwrap();
    let channels = traffic::stress_channels();
    let written = write_all(&mut recorder, &channels, traffic::stress_mix(SECOND_NS));
    let report = recorder.close().unwrap();
    assert!(report.parts.len() >= min_parts, "{:?}", report.parts);
    assert_eq!(report.index, Some(index_path(&path)));

    let index = PartsIndex::read(&index_path(&path)).unwrap();
    let parts = index.part_paths(&index_path(&path));
    assert_eq!(parts, report.parts);
    assert!(index.parts.iter().all(|p| p.complete));
    let total: u64 = index.parts.iter().map(|p| p.message_count).sum();
    assert_eq!(total, report.messages());
    for pair in index.parts.windows(2) {
        assert!(pair[0].last_log_time_ns <= pair[1].first_log_time_ns);
    }
    for part in &parts {
        doctor(part);
    }
    let view = python_read(&parts);
    assert_eq!(view.digests(), written, "the parts read as one run");
    for (i, _) in parts.iter().enumerate() {
        assert_eq!(view.file(i)["profile"], "ros2");
        assert!(view.file(i)["metadata"]["lewis.interfaces"].is_object());
        assert_eq!(view.file(i)["channels"].as_object().unwrap().len(), 22);
    }
}

#[test]
fn rotation_by_size_writes_parts_that_an_index_lists_and_that_read_as_one_run() {
    check_rotation(|o| o.split_size_bytes = Some(8 * 1024 * 1024), 3);
}

#[test]
fn rotation_by_duration_writes_parts_that_an_index_lists_and_that_read_as_one_run() {
    check_rotation(|o| o.split_duration_ns = Some(SECOND_NS / 4), 4);
}

#[test]
fn a_provider_restart_is_a_new_run_and_gaps_are_counted_as_lost() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let mut recorder = Recorder::create(options(&path)).unwrap();
    let channels = &traffic::stress_channels()[..2];
    // Channel 0: 1..=10, restart at 1..=5, then a gap of 3 (9..=12).
    // Channel 1: starts at 100 (recording started late), then a gap of 2 at 103.
    let seqs: [&[u64]; 2] = [
        &[1, 2, 3, 4, 5, 6, 7, 8, 9, 10, 1, 2, 3, 4, 5, 9, 10, 11, 12],
        &[100, 101, 102, 105, 106],
    ];
    let mut messages = Vec::new();
    for (channel, seqs) in seqs.iter().enumerate() {
        for (i, &seq) in seqs.iter().enumerate() {
            let time = i as i64 * 1_000_000 + channel as i64;
            messages.push(Msg {
                channel,
                seq,
                publish_time_ns: time,
                log_time_ns: time,
                data: traffic::small_message(channel, seq, time),
            });
        }
    }
    messages.sort_by_key(|m| m.log_time_ns);
    let written = write_all(&mut recorder, channels, messages.into_iter());
    let counts = recorder.counts();
    assert_eq!(counts["/sensor00/Distance"].lost, 3);
    assert_eq!(counts["/sensor00/Distance"].restarts, 1);
    assert_eq!(counts["/sensor01/Distance"].lost, 2);
    recorder.close().unwrap();

    doctor(&path);
    let view = python_read(std::slice::from_ref(&path));
    assert_eq!(view.digests(), written);
    assert_eq!(
        view.loss(0),
        BTreeMap::from([
            ("/sensor00/Distance".to_owned(), 3),
            ("/sensor01/Distance".to_owned(), 2)
        ])
    );
    assert_eq!(view.last_stats()["/sensor00/Distance"], (19, 3, 0));
}

#[test]
fn chunks_are_closed_at_least_every_flush_period_of_receive_time() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let mut options = options(&path);
    options.chunk_size_bytes = u64::MAX;
    let mut recorder = Recorder::create(options).unwrap();
    let channels = &traffic::stress_channels()[..1];
    let id = recorder.add_channel(channels[0].clone()).unwrap();
    let mut digests = Digests::default();
    // One message every 10 ms for 3.5 s: by each whole second, all messages received a
    // second before are in a closed chunk.
    for seq in 1..=350_u64 {
        let time = seq as i64 * 10_000_000;
        let m = Msg {
            channel: 0,
            seq,
            publish_time_ns: time,
            log_time_ns: time,
            data: traffic::small_message(0, seq, time),
        };
        recorder.write(&sample(id, &m)).unwrap();
        digests.add(&channels[0].topic, seq, &m.data);
        let received_a_second_ago = (seq as i64 - 100).max(0) as u64;
        assert!(
            recorder.durable_messages() >= received_a_second_ago,
            "at {time} ns only {} messages are in closed chunks",
            recorder.durable_messages()
        );
    }
    // Time passes with no message: the last ones are flushed too.
    recorder.tick(351 * 10_000_000 + SECOND_NS).unwrap();
    assert_eq!(recorder.durable_messages(), 350);
    recorder.close().unwrap();
    doctor(&path);
    assert_eq!(python_read(&[path]).digests(), digests.finish());
}

/// A camera frame is written in a chunk of its own, so that a reader of the other topics
/// decompresses no frame; everything still reads back whole.
#[test]
fn large_messages_get_chunks_of_their_own() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("run.mcap");
    let mut recorder = Recorder::create(options(&path)).unwrap();
    let channels = traffic::stress_channels();
    let written = write_all(&mut recorder, &channels, traffic::stress_mix(2 * SECOND_NS));
    recorder.close().unwrap();
    doctor(&path);
    assert_eq!(python_read(std::slice::from_ref(&path)).digests(), written);

    let summary = mcap::Summary::read(&std::fs::read(&path).unwrap())
        .unwrap()
        .unwrap();
    let topic = |id: &u16| summary.channels[id].topic.clone();
    let (mut frames, mut others) = (0, 0);
    for chunk in &summary.chunk_indexes {
        let topics: Vec<String> = chunk.message_index_offsets.keys().map(topic).collect();
        if topics.iter().any(|t| t == "/camera/ImageSource") {
            assert_eq!(topics, ["/camera/ImageSource"], "a frame shares its chunk");
            frames += 1;
        } else {
            others += 1;
        }
    }
    assert!(
        frames > 1 && others > 1,
        "{frames} frame chunks, {others} others"
    );
}
