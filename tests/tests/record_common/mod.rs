//! What the `record_*` tests share: a `lewis record` process, the recording read back
//! with the mcap crate, and the independent Python readers.

#![allow(dead_code, clippy::unwrap_used, clippy::expect_used)]

pub mod stream;

use std::collections::BTreeMap;
use std::io::{BufRead, BufReader};
use std::path::PathBuf;
use std::process::{Child, Command, Stdio};
use std::sync::mpsc::{Receiver, channel};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::Header;
use lewis_runtime::ipc::Namespace;
use lewis_tests::{WATCHDOG, lewis_exe, python_tool, repo_root, run_ok, signal, wait_child};
use serde_json::Value;

/// One message read back from a recording.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Recorded {
    /// The header's sequence number (decoded from the bytes).
    pub seq: u64,
    /// The MCAP publish time.
    pub publish_time_ns: u64,
    /// The MCAP log time.
    pub log_time_ns: u64,
    /// The bytes as written.
    pub data: Vec<u8>,
}

/// A recording read with the mcap crate: messages per topic in file order (the companion
/// channels of ROS 2 types left out), the file metadata, and the channel metadata per
/// topic (every channel, with messages or not).
#[derive(Debug, Default)]
pub struct Recording {
    pub topics: BTreeMap<String, Vec<Recorded>>,
    pub metadata: BTreeMap<String, BTreeMap<String, String>>,
    pub channels: BTreeMap<String, BTreeMap<String, String>>,
}

impl Recording {
    /// Reads `files` as one run.
    pub fn read(files: &[PathBuf]) -> Self {
        let mut recording = Self::default();
        for file in files {
            let bytes = std::fs::read(file)
                .unwrap_or_else(|e| panic!("cannot read {}: {e}", file.display()));
            for message in mcap::MessageStream::new(&bytes).unwrap() {
                let message = message.unwrap();
                let channel = &message.channel;
                recording
                    .channels
                    .entry(channel.topic.clone())
                    .or_insert_with(|| channel.metadata.clone());
                // ROS 2's own types, with no Lewis header: checked against their sources
                // by tools/python/check_companions.py.
                if channel.metadata.get("kind").map(String::as_str)
                    == Some(lewis_recorder::companion::COMPANION_KIND)
                {
                    continue;
                }
                recording
                    .topics
                    .entry(channel.topic.clone())
                    .or_default()
                    .push(Recorded {
                        seq: header_of(&message.data).seq,
                        publish_time_ns: message.publish_time,
                        log_time_ns: message.log_time,
                        data: message.data.into_owned(),
                    });
            }
            let summary = mcap::Summary::read(&bytes).unwrap().expect("a summary");
            // Channels without messages too.
            for channel in summary.channels.values() {
                recording
                    .channels
                    .entry(channel.topic.clone())
                    .or_insert_with(|| channel.metadata.clone());
            }
            for index in &summary.metadata_indexes {
                let metadata = mcap::read::metadata(&bytes, index).unwrap();
                recording
                    .metadata
                    .entry(metadata.name)
                    .or_default()
                    .extend(metadata.metadata);
            }
        }
        recording
    }

    /// The messages of `topic` (none when absent).
    pub fn of(&self, topic: &str) -> &[Recorded] {
        self.topics.get(topic).map_or(&[], Vec::as_slice)
    }

    /// The sequence numbers of `topic` as runs of consecutive numbers.
    pub fn seq_runs(&self, topic: &str) -> Vec<[u64; 2]> {
        runs(self.of(topic).iter().map(|m| m.seq))
    }

    /// `lewis.loss` as numbers.
    pub fn loss(&self) -> BTreeMap<String, u64> {
        self.metadata
            .get(lewis_recorder::LOSS_METADATA)
            .expect("lewis.loss in the file")
            .iter()
            .map(|(k, v)| (k.clone(), v.parse().unwrap()))
            .collect()
    }
}

/// Consecutive numbers grouped into `[first, last]` runs.
pub fn runs(seqs: impl Iterator<Item = u64>) -> Vec<[u64; 2]> {
    let mut runs: Vec<[u64; 2]> = Vec::new();
    for seq in seqs {
        match runs.last_mut() {
            Some(run) if run[1] + 1 == seq => run[1] = seq,
            _ => runs.push([seq, seq]),
        }
    }
    runs
}

/// The header at the start of CDR bytes.
pub fn header_of(bytes: &[u8]) -> Header {
    cdr::peek_header(bytes).expect("a header")
}

/// Decodes a recorded message.
pub fn decode<T: lewis_interfaces::Struct>(message: &Recorded) -> T {
    cdr::from_bytes(&message.data).unwrap()
}

/// Reads `files` (as one run) with mcap + mcap-ros2-support: the JSON of
/// `tools/python/check_recording.py`.
pub fn python_read(files: &[PathBuf]) -> Value {
    let script = repo_root().join("tools/python/check_recording.py");
    serde_json::from_str(&run_ok(python_tool("python").arg(script).args(files))).unwrap()
}

/// Checks that the Python reader decoded every message the mcap crate read, with the same
/// bytes (a CRC per topic) and the same header sequence numbers.
pub fn assert_python_agrees(files: &[PathBuf], recording: &Recording) {
    let python = python_read(files);
    let topics = python["topics"].as_object().unwrap();
    for (topic, messages) in &recording.topics {
        let t = topics
            .get(topic)
            .unwrap_or_else(|| panic!("python did not decode {topic}"));
        assert_eq!(t["count"].as_u64(), Some(messages.len() as u64), "{topic}");
        let mut crc = crc32fast::Hasher::new();
        for m in messages {
            crc.update(&u32::try_from(m.data.len()).unwrap().to_le_bytes());
            crc.update(&m.data);
        }
        assert_eq!(
            t["crc32"].as_u64(),
            Some(u64::from(crc.finalize())),
            "{topic}: python read other bytes"
        );
        let python_runs: Vec<[u64; 2]> = t["seq_runs"]
            .as_array()
            .unwrap()
            .iter()
            .map(|r| [r[0].as_u64().unwrap(), r[1].as_u64().unwrap()])
            .collect();
        assert_eq!(python_runs, recording.seq_runs(topic), "{topic}");
        assert_eq!(t["publish_time_matches"], true, "{topic}");
    }
    assert_eq!(
        topics.len(),
        recording.topics.len(),
        "topics python decoded"
    );
    for file in &python["files"].as_array().unwrap()[..] {
        assert_eq!(file["profile"], "ros2");
        for (topic, channel) in file["channels"].as_object().unwrap() {
            assert_eq!(channel["message_encoding"], "cdr", "{topic}");
            assert_eq!(channel["schema_encoding"], "ros2msg", "{topic}");
        }
    }
}

/// A running `lewis record`, its stdout and stderr read line by line (stderr lines are
/// prefixed with `stderr: `).
pub struct RecordProcess {
    pub child: Child,
    lines: Receiver<String>,
    /// The lines seen so far.
    pub seen: Vec<String>,
}

impl RecordProcess {
    /// Starts `lewis record --namespace NS ARGS...` and waits (watchdog) until it has
    /// subscribed to every channel.
    pub fn start(namespace: &Namespace, args: &[&std::ffi::OsStr]) -> Self {
        Self::start_with(namespace, args, |_| {})
    }

    /// As [`RecordProcess::start`], with the command adjusted by `configure` first.
    pub fn start_with(
        namespace: &Namespace,
        args: &[&std::ffi::OsStr],
        configure: impl FnOnce(&mut Command),
    ) -> Self {
        let mut command = Command::new(lewis_exe());
        command
            .args(["record", "--namespace", namespace.as_str()])
            .args(args)
            .arg("-v")
            .env_remove("RUST_LOG")
            .stdin(Stdio::null())
            .stdout(Stdio::piped())
            .stderr(Stdio::piped());
        configure(&mut command);
        let mut child = command.spawn().expect("lewis record starts");
        let (tx, lines) = channel();
        let stdout = child.stdout.take().unwrap();
        let stderr = child.stderr.take().unwrap();
        for (stream, prefix) in [
            (Box::new(stdout) as Box<dyn std::io::Read + Send>, ""),
            (Box::new(stderr), "stderr: "),
        ] {
            let tx = tx.clone();
            std::thread::spawn(move || {
                for line in BufReader::new(stream).lines() {
                    let Ok(line) = line else { break };
                    if tx.send(format!("{prefix}{line}")).is_err() {
                        break;
                    }
                }
            });
        }
        let mut process = Self {
            child,
            lines,
            seen: Vec::new(),
        };
        loop {
            let line = process.lines.recv_timeout(WATCHDOG).unwrap_or_else(|_| {
                panic!(
                    "lewis record never said it was recording:\n{}",
                    process.seen.join("\n")
                )
            });
            let ready = line.starts_with("recording ");
            process.seen.push(line);
            if ready {
                return process;
            }
        }
    }

    /// Waits (watchdog) for a line containing `needle` and returns it.
    pub fn wait_line(&mut self, needle: &str) -> String {
        loop {
            let line = self.lines.recv_timeout(WATCHDOG).unwrap_or_else(|_| {
                panic!(
                    "lewis record never wrote a line with `{needle}`:\n{}",
                    self.seen.join("\n")
                )
            });
            self.seen.push(line.clone());
            if line.contains(needle) {
                return line;
            }
        }
    }

    /// The ready line (the first line it wrote on stdout).
    pub fn ready_line(&self) -> &str {
        self.seen
            .iter()
            .find(|l| l.starts_with("recording "))
            .map_or("", String::as_str)
    }

    /// Waits (watchdog) for it to end by itself; returns whether it exited with 0, and
    /// everything it wrote.
    pub fn wait(mut self) -> (bool, String) {
        let status = wait_child(&mut self.child);
        while let Ok(line) = self.lines.recv_timeout(WATCHDOG) {
            self.seen.push(line);
        }
        (status.success(), self.seen.join("\n"))
    }

    /// The process id.
    pub fn pid(&self) -> u32 {
        self.child.id()
    }

    /// Stops it with SIGTERM; returns whether it exited with 0, and everything it wrote.
    pub fn stop(mut self) -> (bool, String) {
        signal(self.child.id(), nix::sys::signal::Signal::SIGTERM);
        let status = wait_child(&mut self.child);
        while let Ok(line) = self.lines.recv_timeout(WATCHDOG) {
            self.seen.push(line);
        }
        (status.success(), self.seen.join("\n"))
    }
}

/// The test robot of `robots/test.toml` with faster services (the tests wait for samples)
/// and heartbeat deadlines that a loaded test machine meets.
pub fn test_robot_file() -> String {
    std::fs::read_to_string(repo_root().join("robots/test.toml"))
        .unwrap()
        .replace("rate_hz = 10.0", "rate_hz = 50.0")
        .replace("rate_hz = 5.0", "rate_hz = 25.0")
        .replace(
            "heartbeat_deadline_ms = 50\n",
            "heartbeat_deadline_ms = 1000\n",
        )
}

/// Checks that every provider channel that holds messages holds every sequence number of
/// each run of its provider from 1 (the recorder subscribed before any service started).
pub fn assert_every_run_complete(recording: &Recording, topic: &str) {
    let runs = recording.seq_runs(topic);
    assert!(!runs.is_empty(), "{topic} holds no message");
    for run in &runs {
        assert_eq!(
            run[0], 1,
            "{topic}: a run of its provider misses its start: {runs:?}"
        );
    }
}
