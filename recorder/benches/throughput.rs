//! Recorder throughput against the bare mcap crate, and the recorder's peak memory.
//!
//! `cargo bench -p lewis-recorder --bench throughput` runs, once:
//! 1. memory: the stress mix (20 channels at 1 kHz of small messages and a 640x480 RGB
//!    stream at 30 Hz) through the tap and the writer thread with the default queue,
//!    first at its real rate for a few seconds, then offered as fast as possible (the
//!    queue full all the time: the worst case); peak resident memory of each phase
//!    (VmHWM, reset between phases through /proc/self/clear_refs);
//! 2. throughput: the same messages written by the bare mcap crate in one loop
//!    (baseline: same compression, 1 MiB chunks) and by the recorder, side by side, for
//!    zstd, lz4 and none, with the stress mix and with 1 KiB messages: the core alone; the
//!    tap, the real bounded queue (the defaults) and the writer thread, offered as fast as
//!    the tap takes them (what the pipeline sustains; what it cannot take is dropped and
//!    counted); the same pipeline offered at 0.9x the baseline's rate (it must drop
//!    nothing); and the core with its default sync at each timed flush (the cost of
//!    surviving a power cut). MB/s counts the bytes of the messages written (10^6 bytes).

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

#[path = "../tests/common/traffic.rs"]
mod traffic;

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
    lewis_stdx::peak_resident_kib().unwrap()
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
    let mut batch = tap.batch();
    for m in traffic::stress_mix(seconds * SECOND_NS) {
        if paced {
            let due = Duration::from_nanos(m.log_time_ns as u64);
            if let Some(wait) = due.checked_sub(start.elapsed()) {
                std::thread::sleep(wait);
            }
        }
        offered += 1;
        let _ = batch.record(&sample(ids[m.channel], &m));
        if paced {
            // At its real rate the live tap hands over what one wake-up took.
            let _ = batch.flush();
        }
    }
    drop(batch);
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

/// What a run through the tap, the bounded queue and the writer thread did.
struct PipelineRun {
    seconds: f64,
    written_bytes: u64,
    dropped: u64,
}

/// The tap, the real bounded queue ([`QueueOptions::default`]) and the writer thread.
/// Messages are offered as fast as the tap takes them, or paced at `bytes_per_sec`.
fn recorder_pipeline(
    path: &Path,
    compression: Compression,
    channels: &[ChannelSpec],
    messages: &[Msg],
    bytes_per_sec: Option<f64>,
) -> PipelineRun {
    let recorder = Recorder::create(recorder_options(path, compression, false)).unwrap();
    let start = Instant::now();
    let (tap, writer) = spawn(recorder, QueueOptions::default(), move || {
        i64::try_from(start.elapsed().as_nanos()).unwrap_or(i64::MAX)
    })
    .unwrap();
    let ids: Vec<_> = channels.iter().map(|c| tap.register(c.clone())).collect();
    let mut offered_bytes = 0_u64;
    let mut written_bytes = 0_u64;
    // As the live tap does with what one wake-up takes.
    let mut batch = tap.batch();
    for m in messages {
        if let Some(rate) = bytes_per_sec {
            // The moment this message's bytes are due at that rate.
            let due = Duration::from_secs_f64(offered_bytes as f64 / rate);
            while start.elapsed() < due {
                std::hint::spin_loop();
            }
        }
        offered_bytes += m.data.len() as u64;
        if batch.record(&sample(ids[m.channel], m)).is_ok() {
            written_bytes += m.data.len() as u64;
        }
    }
    drop(batch);
    let dropped = tap.dropped_total();
    let report = writer.finish().unwrap();
    assert_eq!(
        report.counts.values().map(|c| c.dropped).sum::<u64>(),
        dropped
    );
    PipelineRun {
        seconds: start.elapsed().as_secs_f64(),
        written_bytes,
        dropped,
    }
}

/// Runs of each variant; the median is reported (the machine is shared).
const RUNS: usize = 3;

/// The median of `RUNS` runs of `f`, which returns (seconds, bytes written); the file at
/// `path` is removed after each run but the last.
fn median_mb_per_sec(path: &Path, mut f: impl FnMut() -> (f64, u64)) -> f64 {
    let mut rates: Vec<f64> = (0..RUNS)
        .map(|run| {
            let (seconds, bytes) = f();
            if run + 1 < RUNS {
                std::fs::remove_file(path).unwrap();
            }
            bytes as f64 / 1e6 / seconds
        })
        .collect();
    rates.sort_by(f64::total_cmp);
    rates[RUNS / 2]
}

fn timed(bytes: u64, f: impl FnOnce()) -> (f64, u64) {
    let start = Instant::now();
    f();
    (start.elapsed().as_secs_f64(), bytes)
}

fn throughput(dir: &Path, workload: &str, channels: &[ChannelSpec], messages: &[Msg]) {
    let bytes: u64 = messages.iter().map(|m| m.data.len() as u64).sum();
    let mb = bytes as f64 / 1e6;
    for compression in [Compression::Zstd, Compression::Lz4, Compression::None] {
        let path = |what: &str| dir.join(format!("{workload}-{compression}-{what}.mcap"));
        let base = median_mb_per_sec(&path("baseline"), || {
            timed(bytes, || {
                baseline(&path("baseline"), compression, channels, messages);
            })
        });
        let core = median_mb_per_sec(&path("recorder"), || {
            timed(bytes, || {
                recorder_core(&path("recorder"), compression, false, channels, messages);
            })
        });
        let synced = median_mb_per_sec(&path("synced"), || {
            timed(bytes, || {
                recorder_core(&path("synced"), compression, true, channels, messages);
            })
        });
        let mut flat_out_dropped = Vec::new();
        let pipe = median_mb_per_sec(&path("pipeline"), || {
            let run = recorder_pipeline(&path("pipeline"), compression, channels, messages, None);
            flat_out_dropped.push(run.dropped);
            (run.seconds, run.written_bytes)
        });
        std::fs::remove_file(path("pipeline")).unwrap();
        let paced = recorder_pipeline(
            &path("pipeline"),
            compression,
            channels,
            messages,
            Some(0.9 * base * 1e6),
        );
        println!(
            "{workload:<10} {compression:<5} {mb:6.1} MB | baseline {base:6.1} MB/s | recorder {core:6.1} MB/s {:.2}x | tap+bounded queue+writer flat out {pipe:6.1} MB/s {:.2}x (dropped {flat_out_dropped:?}); offered at 0.9x baseline: {} dropped | recorder synced each second {synced:6.1} MB/s {:.2}x | sizes {:.1} / {:.1} MB",
            core / base,
            pipe / base,
            paced.dropped,
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

    let stress: Vec<Msg> = traffic::stress_mix(10 * SECOND_NS).collect();
    throughput(
        dir.path(),
        "stress mix",
        &traffic::stress_channels(),
        &stress,
    );
    drop(stress);
    let kib: Vec<Msg> = traffic::kib_messages(300_000).collect();
    throughput(dir.path(), "1 KiB", &traffic::kib_channels(), &kib);
}
