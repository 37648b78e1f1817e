//! Zero loss under stress, end to end with real processes: the stress mix (20 channels at
//! 1 kHz of small messages and a 640x480 RGB stream at 30 Hz, about 30 MB/s) published for
//! 30 s by `lewis stress-publish`, recorded by two `lewis record` processes at once: one as
//! shipped, which must lose nothing, and one whose disk writer is deliberately slowed
//! (`--test-write-delay-us`, a small queue), which must count exactly what it loses, while
//! the publisher keeps its rate (it never waits for a reader).
//!
//! The one long test of the suite: the requirement is 30 s of traffic (about 40 s in all).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stderr)]

mod record_common;

use std::ffi::OsStr;
use std::process::{Command, Stdio};
use std::time::Duration;

use lewis_runtime::ipc::Namespace;
use lewis_tests::{WATCHDOG, lewis_exe, wait_child_within};
use record_common::RecordProcess;
use record_common::stream::Streamed;
use serde_json::Value;

/// Seconds of traffic, as required.
const SECONDS: u64 = 30;

/// The slowed writer: a pause after each message (about 6,000 messages a second at most,
/// a third of the mix) and a queue of 1,000 messages.
const SLOW_WRITE_DELAY_US: &str = "100";
const SLOW_QUEUE_MESSAGES: &str = "1000";

/// The least part of its nominal rate the publisher must keep while the slow recorder
/// drops: it never waits for a reader, so only the machine's load could slow it.
const RATE_KEPT: f64 = 0.95;

/// The peak resident memory a recorder printed at its end, in MiB.
fn peak_mib(output: &str) -> f64 {
    output
        .lines()
        .find_map(|l| l.split("peak resident memory ").nth(1))
        .and_then(|rest| rest.split_whitespace().next())
        .and_then(|n| n.parse().ok())
        .unwrap_or_else(|| panic!("no peak resident memory in:\n{output}"))
}

#[test]
fn thirty_seconds_of_the_stress_mix_lose_nothing_and_a_slowed_writer_counts_every_loss() {
    let dir = tempfile::tempdir().unwrap();
    let namespace = Namespace::unique("record-stress");
    let robot = dir.path().join("stress.toml");
    std::fs::write(&robot, lewis_recorder::stress::robot_toml()).unwrap();
    let lossless_path = dir.path().join("lossless.mcap");
    let slow_path = dir.path().join("slow.mcap");
    let lossless = RecordProcess::start(
        &namespace,
        &[
            OsStr::new("--robot"),
            robot.as_os_str(),
            OsStr::new("-o"),
            lossless_path.as_os_str(),
        ],
    );
    let slow = RecordProcess::start(
        &namespace,
        &[
            OsStr::new("--robot"),
            robot.as_os_str(),
            OsStr::new("-o"),
            slow_path.as_os_str(),
            OsStr::new("--compression"),
            OsStr::new("lz4"),
            OsStr::new("--test-write-delay-us"),
            OsStr::new(SLOW_WRITE_DELAY_US),
            OsStr::new("--test-queue-messages"),
            OsStr::new(SLOW_QUEUE_MESSAGES),
        ],
    );

    // Both recorders have subscribed: nothing published from now on is missed by them.
    let report_path = dir.path().join("load.json");
    let mut publisher = Command::new(lewis_exe())
        .args(["stress-publish", "--namespace", namespace.as_str()])
        .args(["--duration", &format!("{SECONDS}s")])
        .arg("--report")
        .arg(&report_path)
        .stdin(Stdio::null())
        .spawn()
        .unwrap();
    let status = wait_child_within(&mut publisher, Duration::from_secs(SECONDS) + WATCHDOG);
    assert!(status.success(), "lewis stress-publish failed: {status}");
    let load: Value = serde_json::from_slice(&std::fs::read(&report_path).unwrap()).unwrap();

    let (ok, lossless_out) = lossless.stop();
    assert!(ok, "{lossless_out}");
    let (ok, slow_out) = slow.stop();
    assert!(ok, "{slow_out}");
    let lossless = Streamed::read(&lossless_path);
    let slow = Streamed::read(&slow_path);

    let mut slow_dropped = 0;
    let mut slow_written = 0;
    for channel in load["channels"].as_array().unwrap() {
        let topic = channel["topic"].as_str().unwrap();
        let published = channel["published"].as_u64().unwrap();
        // The recorder as shipped: every sequence number, nothing counted lost.
        let seqs = &lossless.topics[topic];
        assert_eq!(seqs.runs, [[1, published]], "{topic}: sequence numbers");
        assert_eq!(seqs.publish_time_mismatches, 0, "{topic}");
        assert_eq!(lossless.loss_of(topic), 0, "{topic}: lewis.loss");
        let as_i64 = |n: u64| i64::try_from(n).unwrap();
        assert_eq!(
            lossless.stats_of(topic),
            (as_i64(published), 0, 0),
            "{topic}: (written, lost, dropped) of the stats message"
        );

        // The slowed one: the losses it counts are the gaps in its file, and every
        // message published is either in the file or counted as dropped.
        let seqs = slow.topics.get(topic).cloned().unwrap_or_default();
        let (written, lost, dropped) = slow.stats_of(topic);
        assert_eq!(written, as_i64(seqs.count), "{topic}: written");
        assert_eq!(
            lost,
            as_i64(seqs.gaps()),
            "{topic}: lost = the gaps in the file"
        );
        assert_eq!(slow.loss_of(topic), seqs.gaps(), "{topic}: lewis.loss");
        assert_eq!(
            written + dropped,
            as_i64(published),
            "{topic}: a message neither written nor counted as dropped"
        );
        slow_dropped += dropped;
        slow_written += written;

        // The publisher kept its rate while the slow recorder dropped.
        let nominal = channel["nominal_hz"].as_f64().unwrap();
        let achieved = channel["achieved_hz"].as_f64().unwrap();
        assert!(
            achieved >= RATE_KEPT * nominal,
            "{topic}: published at {achieved:.1} Hz, nominal {nominal} Hz ({load})"
        );
    }
    assert!(
        slow_dropped > 0,
        "the slowed writer dropped nothing: it was not slow enough"
    );
    let lossless_mib = peak_mib(&lossless_out);
    let slow_mib = peak_mib(&slow_out);
    eprintln!(
        "stress mix for {SECONDS} s: publisher {} s, max {:.1} ms late, longest publication \
         {:.0} µs; recorder as shipped: every message, peak {lossless_mib:.1} MiB, {:.0} MB; \
         slowed writer: {slow_written} written, {slow_dropped} dropped and counted, peak \
         {slow_mib:.1} MiB",
        load["elapsed_secs"],
        load["max_late_ms"].as_f64().unwrap(),
        load["max_publish_us"].as_f64().unwrap(),
        std::fs::metadata(&lossless_path).unwrap().len() as f64 / 1e6,
    );
    // The queue bounds hold the recorder's memory (goal: under 100 MiB).
    assert!(lossless_mib < 100.0, "{lossless_out}");
    assert!(slow_mib < 100.0, "{slow_out}");
}
