//! Recorder throughput against the bare mcap crate, and the recorder's peak memory.
//!
//! `cargo bench -p lewis-recorder --bench throughput` runs, once:
//! 1. memory: the stress mix (20 channels at 1 kHz of small messages and a 640x480 RGB
//!    stream at 30 Hz) through the tap and the writer thread with the default queue,
//!    first at its real rate for a few seconds, then offered as fast as possible (the
//!    queue full all the time: the worst case); peak resident memory of each phase
//!    (VmHWM, reset between phases through /proc/self/clear_refs);
//! 2. throughput: the same messages written by the bare mcap crate in one loop
//!    (baseline: same compression, 1 MiB chunks) and by the recorder (core alone, and
//!    tap + queue + writer thread), side by side, for zstd, lz4 and none, with the stress
//!    mix and with 1 KiB messages. MB/s counts message bytes (10^6 bytes). The recorder
//!    runs without syncing (like the baseline), and with its default sync at each timed
//!    flush (the cost of surviving a power cut).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

#[path = "../tests/common/traffic.rs"]
mod traffic;

use std::collections::BTreeMap;
use std::fs::File;
use std::io::BufWriter;
use std::path::Path;
use std::time::{Duration, Instant};

use lewis_recorder::{
    ChannelSpec, Compression, QueueOptions, Recorder, RecorderOptions, SECOND_NS, Sample, spawn,
};
use mcap::records::MessageHeader;
use traffic::Msg;

fn peak_rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmHWM:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

fn current_rss_kib() -> u64 {
    let status = std::fs::read_to_string("/proc/self/status").unwrap();
    let line = status.lines().find(|l| l.starts_with("VmRSS:")).unwrap();
    line.split_whitespace().nth(1).unwrap().parse().unwrap()
}

fn reset_peak_rss() {
    std::fs::write("/proc/self/clear_refs", "5").unwrap();
}

fn sample(channel: lewis_recorder::ChannelId, m: &Msg) -> Sample<'_> {
    Sample {
        channel,
        seq: m.seq,
        publish_time_ns: m.publish_time_ns,
        log_time_ns: m.log_time_ns,
        data: &m.data,
    }
}

/// The stress mix through the tap for `seconds`, paced at its real rate or not.
fn memory_phase(dir: &Path, name: &str, seconds: i64, paced: bool) {
    reset_peak_rss();
    let before = current_rss_kib();
    let path = dir.join(format!("memory-{name}.mcap"));
    let recorder = Recorder::create(RecorderOptions::new(&path)).unwrap();
    let start = Instant::now();
    let (tap, writer) = spawn(recorder, QueueOptions::default(), move || {
        i64::try_from(start.elapsed().as_nanos()).unwrap_or(i64::MAX)
    })
    .unwrap();
    let channels = traffic::stress_channels();
    let ids: Vec<_> = channels.iter().map(|c| tap.register(c.clone())).collect();
    let mut offered = 0_u64;
    for m in traffic::stress_mix(seconds * SECOND_NS) {
        if paced {
            let due = Duration::from_nanos(m.log_time_ns as u64);
            if let Some(wait) = due.checked_sub(start.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        offered += 1;
        let _ = tap.try_record(&sample(ids[m.channel], &m));
    }
    let dropped = tap.dropped_total();
    let report = writer.finish().unwrap();
    println!(
        "memory, stress mix {name} for {seconds} s of traffic: peak RSS {:.1} MiB (process before: {:.1} MiB); offered {offered}, dropped at the tap {dropped}, lost (gaps) {}",
        peak_rss_kib() as f64 / 1024.0,
        before as f64 / 1024.0,
        report.lost()
    );
}

fn to_mcap(compression: Compression) -> Option<mcap::Compression> {
    match compression {
        Compression::Zstd => Some(mcap::Compression::Zstd),
        Compression::Lz4 => Some(mcap::Compression::Lz4),
        Compression::None => None,
    }
}

/// The baseline: the bare mcap crate, one loop, default 1 MiB chunks.
fn baseline(path: &Path, compression: Compression, channels: &[ChannelSpec], messages: &[Msg]) {
    let file = BufWriter::with_capacity(256 * 1024, File::create(path).unwrap());
    let mut writer = mcap::WriteOptions::new()
        .profile("ros2")
        .compression(to_mcap(compression))
        .create(file)
        .unwrap();
    let ids: Vec<u16> = channels
        .iter()
        .map(|c| {
            let schema = writer
                .add_schema(&c.schema_name, "ros2msg", c.schema_text.as_bytes())
                .unwrap();
            writer
                .add_channel(schema, &c.topic, "cdr", &c.metadata())
                .unwrap()
        })
        .collect();
    for m in messages {
        writer
            .write_to_known_channel(
                &MessageHeader {
                    channel_id: ids[m.channel],
                    sequence: m.seq as u32,
                    log_time: m.log_time_ns as u64,
                    publish_time: m.publish_time_ns as u64,
                },
                &m.data,
            )
            .unwrap();
    }
    writer.finish().unwrap();
}

fn recorder_options(path: &Path, compression: Compression, sync: bool) -> RecorderOptions {
    let mut options = RecorderOptions::new(path);
    options.compression = compression;
    options.sync_on_flush = sync;
    options
}

fn recorder_core(
    path: &Path,
    compression: Compression,
    sync: bool,
    channels: &[ChannelSpec],
    messages: &[Msg],
) {
    let mut recorder = Recorder::create(recorder_options(path, compression, sync)).unwrap();
    let ids: Vec<_> = channels
        .iter()
        .map(|c| recorder.add_channel(c.clone()).unwrap())
        .collect();
    for m in messages {
        recorder.write(&sample(ids[m.channel], m)).unwrap();
    }
    recorder.close().unwrap();
}

fn recorder_pipeline(
    path: &Path,
    compression: Compression,
    channels: &[ChannelSpec],
    messages: &[Msg],
) {
    let recorder = Recorder::create(recorder_options(path, compression, false)).unwrap();
    // A queue that holds the whole run: this measures the writer, not the drop policy.
    let queue = QueueOptions {
        capacity_messages: messages.len() + 1,
        capacity_bytes: usize::MAX / 2,
        ..QueueOptions::default()
    };
    let (tap, writer) = spawn(recorder, queue, || 0).unwrap();
    let ids: Vec<_> = channels.iter().map(|c| tap.register(c.clone())).collect();
    for m in messages {
        tap.try_record(&sample(ids[m.channel], m)).unwrap();
    }
    let report = writer.finish().unwrap();
    assert_eq!(report.lost(), 0);
}

fn timed(f: impl FnOnce()) -> f64 {
    let start = Instant::now();
    f();
    start.elapsed().as_secs_f64()
}

fn throughput(dir: &Path, workload: &str, channels: &[ChannelSpec], messages: &[Msg]) {
    let bytes: u64 = messages.iter().map(|m| m.data.len() as u64).sum();
    let mb = bytes as f64 / 1e6;
    for compression in [Compression::Zstd, Compression::Lz4, Compression::None] {
        let mut seconds = BTreeMap::new();
        let path = |what: &str| dir.join(format!("{workload}-{compression}-{what}.mcap"));
        seconds.insert(
            "baseline",
            timed(|| baseline(&path("baseline"), compression, channels, messages)),
        );
        seconds.insert(
            "recorder",
            timed(|| recorder_core(&path("recorder"), compression, false, channels, messages)),
        );
        seconds.insert(
            "synced",
            timed(|| recorder_core(&path("synced"), compression, true, channels, messages)),
        );
        seconds.insert(
            "pipeline",
            timed(|| recorder_pipeline(&path("pipeline"), compression, channels, messages)),
        );
        let base = mb / seconds["baseline"];
        let core = mb / seconds["recorder"];
        let synced = mb / seconds["synced"];
        let pipe = mb / seconds["pipeline"];
        println!(
            "{workload:<10} {compression:<5} {mb:5.1} MB | baseline {base:6.1} MB/s | recorder {core:6.1} MB/s {:.2}x | tap+queue+writer {pipe:6.1} MB/s {:.2}x | recorder synced each second {synced:6.1} MB/s {:.2}x | sizes {:.1} / {:.1} MB",
            core / base,
            pipe / base,
            synced / base,
            std::fs::metadata(path("baseline")).unwrap().len() as f64 / 1e6,
            std::fs::metadata(path("recorder")).unwrap().len() as f64 / 1e6,
        );
        for what in ["baseline", "recorder", "synced", "pipeline"] {
            std::fs::remove_file(path(what)).unwrap();
        }
    }
}

fn main() {
    if std::env::args().any(|a| a == "--list") {
        return;
    }
    let dir = tempfile::tempdir_in(std::env::var_os("BENCH_DIR").unwrap_or_else(|| "/tmp".into()))
        .unwrap();
    memory_phase(dir.path(), "at its real rate", 5, true);
    memory_phase(dir.path(), "offered as fast as possible", 5, false);

    let stress: Vec<Msg> = traffic::stress_mix(2 * SECOND_NS).collect();
    throughput(
        dir.path(),
        "stress mix",
        &traffic::stress_channels(),
        &stress,
    );
    drop(stress);
    let kib: Vec<Msg> = traffic::kib_messages(60_000).collect();
    throughput(dir.path(), "1 KiB", &traffic::kib_channels(), &kib);
}
