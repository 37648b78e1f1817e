//! What the companion channels (ROS 2 views beside Lewis's own messages) cost the
//! recorder: the same messages written by the recorder's core with companions off and on,
//! side by side in one run, median of a few runs each.
//!
//! `cargo bench -p lewis-recorder --bench companions` writes:
//! - the stress mix (20 channels of Distance at 1 kHz and a 640x480 RGB camera at 30 Hz,
//!   about 30 MB/s), 4 s of it: nothing of it is converted but the check of each message;
//!   and with the images as PNG companions (`--companion-images`), the cost of a second,
//!   compressed copy of every frame;
//! - the simulated robot's own traffic, `tests/data/reference/sim-goal.mcap` (laser at 10 Hz,
//!   odometry at 50 Hz, health, commands, the broker), every message converted where it
//!   has a view: LaserScan, Odometry, tf, markers.
//!
//! MB/s counts the bytes of the source messages (10^6 bytes), zstd, 1 MiB chunks.

#![allow(clippy::unwrap_used, clippy::expect_used, clippy::print_stdout)]

#[path = "../tests/common/traffic.rs"]
mod traffic;

use std::collections::BTreeMap;
use std::path::Path;
use std::time::Instant;

use lewis_recorder::companion::{CompanionOptions, ImageCodec};
use lewis_recorder::{ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};
use traffic::Msg;

const RUNS: usize = 5;

/// Messages and their channels, as the recorder takes them.
struct Workload {
    name: &'static str,
    channels: Vec<ChannelSpec>,
    messages: Vec<Msg>,
    robot: Option<RobotDescription>,
}

/// Writes the workload once; seconds taken.
fn write(path: &Path, workload: &Workload, companions: Option<CompanionOptions>) -> f64 {
    let _ = std::fs::remove_file(path);
    let mut options = RecorderOptions::new(path);
    options.sync_on_flush = false;
    options.robot_description.clone_from(&workload.robot);
    options.companions = companions;
    let start = Instant::now();
    let mut recorder = Recorder::create(options).unwrap();
    let ids: Vec<_> = workload
        .channels
        .iter()
        .map(|c| recorder.add_channel(c.clone()).unwrap())
        .collect();
    for m in &workload.messages {
        recorder
            .write(&Sample {
                channel: ids[m.channel],
                seq: m.seq,
                publish_time_ns: m.publish_time_ns,
                log_time_ns: m.log_time_ns,
                data: &m.data,
            })
            .unwrap();
    }
    recorder.close().unwrap();
    start.elapsed().as_secs_f64()
}

/// MB/s of the source bytes, the median of `RUNS` runs.
fn median_mb_per_sec(
    path: &Path,
    workload: &Workload,
    companions: Option<CompanionOptions>,
) -> f64 {
    let bytes: u64 = workload.messages.iter().map(|m| m.data.len() as u64).sum();
    let mut rates: Vec<f64> = (0..RUNS)
        .map(|_| bytes as f64 / 1e6 / write(path, workload, companions))
        .collect();
    rates.sort_by(f64::total_cmp);
    rates[RUNS / 2]
}

/// The simulated robot's recording, as messages on channels.
fn sim_goal() -> Workload {
    let path = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tests/data/reference/sim-goal.mcap");
    let bytes = std::fs::read(&path).unwrap();
    let mut channels = Vec::new();
    let mut index: BTreeMap<u16, usize> = BTreeMap::new();
    let mut messages = Vec::new();
    for message in mcap::MessageStream::new(&bytes).unwrap() {
        let message = message.unwrap();
        let channel = &message.channel;
        // The recorder's own stats are its own.
        if channel.topic == lewis_recorder::STATS_TOPIC {
            continue;
        }
        let n = *index.entry(channel.id).or_insert_with(|| {
            let schema = channel.schema.as_ref().unwrap();
            let meta = &channel.metadata;
            let get = |k: &str| meta.get(k).cloned().unwrap_or_default();
            channels.push(ChannelSpec {
                topic: channel.topic.clone(),
                schema_name: schema.name.clone(),
                schema_text: String::from_utf8_lossy(&schema.data).into_owned(),
                provider: get("provider"),
                interface: get("interface"),
                interface_version: get("interface_version"),
                extra_metadata: meta.clone(),
            });
            channels.len() - 1
        });
        messages.push(Msg {
            channel: n,
            seq: u64::from(message.sequence),
            publish_time_ns: i64::try_from(message.publish_time).unwrap(),
            log_time_ns: i64::try_from(message.log_time).unwrap(),
            data: message.data.into_owned(),
        });
    }
    Workload {
        name: "simulated robot (sim-goal.mcap)",
        channels,
        messages,
        robot: None,
    }
}

fn main() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("bench.mcap");
    let stress = Workload {
        name: "stress mix, 4 s",
        channels: traffic::stress_channels(),
        messages: traffic::stress_mix(4 * lewis_recorder::SECOND_NS).collect(),
        robot: None,
    };
    let robot = sim_goal();
    println!("| traffic | companions off | companions on | cost |");
    println!("|---|---|---|---|");
    let on = Some(CompanionOptions::default());
    for workload in [&stress, &robot] {
        let off_rate = median_mb_per_sec(&path, workload, None);
        let on_rate = median_mb_per_sec(&path, workload, on);
        println!(
            "| {} | {off_rate:.0} MB/s | {on_rate:.0} MB/s | {:.1}% |",
            workload.name,
            100.0 * (1.0 - on_rate / off_rate)
        );
    }
    let images = Some(CompanionOptions {
        images: Some(ImageCodec::Png),
    });
    let off_rate = median_mb_per_sec(&path, &stress, None);
    let png_rate = median_mb_per_sec(&path, &stress, images);
    println!(
        "| {}, images as PNG too | {off_rate:.0} MB/s | {png_rate:.0} MB/s | {:.1}% |",
        stress.name,
        100.0 * (1.0 - png_rate / off_rate)
    );
}
