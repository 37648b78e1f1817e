//! What the recorder's tests share: traffic, the independent Python readers, and the
//! digests to compare with what they read.

// Helpers of tests, as the files that use them: a failed unwrap is the test failing.
#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod traffic;

use std::collections::BTreeMap;
use std::path::{Path, PathBuf};

use lewis_recorder::{ChannelSpec, Recorder, RecorderOptions, RobotDescription, Sample};
use lewis_testkit::{python_tool, run_ok};
use serde_json::Value;

use traffic::Msg;

/// What was written on one topic, as the Python reader reports it.
#[derive(Debug, Clone, Default, PartialEq, Eq)]
pub struct TopicDigest {
    pub count: u64,
    pub crc32: u32,
    /// Runs of consecutive sequence numbers: `[first, last]`.
    pub seq_runs: Vec<[u64; 2]>,
}

/// Accumulates the digests of messages, per topic, in the order given.
#[derive(Debug, Default)]
pub struct Digests {
    pub topics: BTreeMap<String, TopicDigest>,
    hashers: BTreeMap<String, crc32fast::Hasher>,
}

impl Digests {
    pub fn add(&mut self, topic: &str, seq: u64, data: &[u8]) {
        let digest = self.topics.entry(topic.to_owned()).or_default();
        digest.count += 1;
        match digest.seq_runs.last_mut() {
            Some(run) if run[1] + 1 == seq => run[1] = seq,
            _ => digest.seq_runs.push([seq, seq]),
        }
        let hasher = self.hashers.entry(topic.to_owned()).or_default();
        hasher.update(&(data.len() as u32).to_le_bytes());
        hasher.update(data);
    }

    pub fn finish(mut self) -> BTreeMap<String, TopicDigest> {
        for (topic, hasher) in std::mem::take(&mut self.hashers) {
            self.topics.get_mut(&topic).unwrap().crc32 = hasher.finalize();
        }
        self.topics
    }
}

/// What the independent Python readers found in a set of files read as one run.
#[derive(Debug)]
pub struct PythonView {
    pub json: Value,
}

impl PythonView {
    /// The digests of every topic but the recorder's stats.
    pub fn digests(&self) -> BTreeMap<String, TopicDigest> {
        self.json["topics"]
            .as_object()
            .unwrap()
            .iter()
            .filter(|(topic, _)| *topic != lewis_recorder::STATS_TOPIC)
            .map(|(topic, t)| {
                let runs = t["seq_runs"]
                    .as_array()
                    .unwrap()
                    .iter()
                    .map(|r| [r[0].as_u64().unwrap(), r[1].as_u64().unwrap()])
                    .collect();
                assert_eq!(
                    t["publish_time_matches"], true,
                    "{topic}: a decoded header publish time differs from the MCAP publish_time"
                );
                (
                    topic.clone(),
                    TopicDigest {
                        count: t["count"].as_u64().unwrap(),
                        crc32: t["crc32"].as_u64().unwrap() as u32,
                        seq_runs: runs,
                    },
                )
            })
            .collect()
    }

    /// The file's entry (`profile`, `metadata`, `channels`, `compressions`).
    pub fn file(&self, index: usize) -> &Value {
        &self.json["files"][index]
    }

    /// The `lewis.loss` metadata of file `index`, as numbers.
    pub fn loss(&self, index: usize) -> BTreeMap<String, u64> {
        self.file(index)["metadata"][lewis_recorder::LOSS_METADATA]
            .as_object()
            .unwrap_or_else(|| panic!("no lewis.loss in file {index}: {}", self.file(index)))
            .iter()
            .map(|(k, v)| (k.clone(), v.as_str().unwrap().parse().unwrap()))
            .collect()
    }

    /// The last stats message decoded: per topic, (written, lost, dropped).
    pub fn last_stats(&self) -> BTreeMap<String, (i64, i64, i64)> {
        let last = &self.json["topics"][lewis_recorder::STATS_TOPIC]["last_decoded"];
        let topics = last["topics"].as_array().unwrap();
        topics
            .iter()
            .enumerate()
            .map(|(i, topic)| {
                (
                    topic.as_str().unwrap().to_owned(),
                    (
                        last["written"][i].as_i64().unwrap(),
                        last["lost"][i].as_i64().unwrap(),
                        last["dropped"][i].as_i64().unwrap(),
                    ),
                )
            })
            .collect()
    }
}

/// Reads `files` (as one run) with mcap + mcap-ros2-support.
pub fn python_read(files: &[PathBuf]) -> PythonView {
    let script = Path::new(env!("CARGO_MANIFEST_DIR")).join("../tools/python/check_recording.py");
    let stdout = run_ok(python_tool("python").arg(script).args(files));
    PythonView {
        json: serde_json::from_str(&stdout).unwrap(),
    }
}

/// Recorder options for tests: small reserve, no sync (tmpfs-like speed).
pub fn options(path: &Path) -> RecorderOptions {
    let mut options = RecorderOptions::new(path);
    options.sync_on_flush = false;
    options.disk_reserve_bytes = 256 * 1024;
    options.robot_description = Some(RobotDescription {
        file_name: "sim.toml".to_owned(),
        toml: "[robot]\nname = \"test\"\n".to_owned(),
    });
    options
}

/// Registers `channels` and writes `messages` with the core; returns the digests of what
/// was written.
pub fn write_all(
    recorder: &mut Recorder,
    channels: &[ChannelSpec],
    messages: impl Iterator<Item = Msg>,
) -> BTreeMap<String, TopicDigest> {
    let ids: Vec<_> = channels
        .iter()
        .map(|c| recorder.add_channel(c.clone()).unwrap())
        .collect();
    let mut digests = Digests::default();
    for m in messages {
        recorder.write(&sample(ids[m.channel], &m)).unwrap();
        digests.add(&channels[m.channel].topic, m.seq, &m.data);
    }
    digests.finish()
}

pub fn sample(channel: lewis_recorder::ChannelId, m: &Msg) -> Sample<'_> {
    Sample {
        channel,
        seq: m.seq,
        publish_time_ns: m.publish_time_ns,
        log_time_ns: m.log_time_ns,
        data: &m.data,
    }
}
