//! The player's controls on real IPC: a playback started paused publishes one message per
//! step and resumes on its command; commands arrive through a socket, as the terminal's keys
//! do through stdin. No timing is assumed: each step is awaited on the subscriber.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::io::{Read, Write};
use std::os::fd::{AsFd, BorrowedFd};
use std::os::unix::net::UnixStream;
use std::path::Path;
use std::time::{Duration, Instant};

use lewis_interfaces::cdr;
use lewis_interfaces::msg::{Header, RangeFinder};
use lewis_recorder::{ChannelSpec, Recorder, RecorderOptions, Sample};
use lewis_recording::play::{Controls, PlayCommand, PlayOptions, PlayReport, play};
use lewis_runtime::ipc::{Ipc, Namespace, Subscriber, WaitSet, WakeMode};
use lewis_runtime::live::StopSignals;
use lewis_runtime::names;

const TOPIC: &str = "/laser/RangeFinder";
const WATCHDOG: Duration = Duration::from_secs(30);

/// Five scans, one a second.
fn recording(path: &Path) -> Vec<Vec<u8>> {
    let mut recorder = Recorder::create(RecorderOptions::new(path)).unwrap();
    let info = lewis_interfaces::interface_info("RangeFinder").unwrap();
    let channel = recorder
        .add_channel(ChannelSpec::publication(info, "laser", TOPIC))
        .unwrap();
    let mut all = Vec::new();
    for k in 1..=5u32 {
        let time_ns = i64::from(k) * 1_000_000_000;
        let scan = RangeFinder {
            header: Header {
                provider: "laser".into(),
                seq: u64::from(k),
                publish_time_ns: time_ns,
                inputs: Vec::new(),
            },
            range_count: 1,
            ranges: vec![f64::from(k)],
            sensor_positions: vec![Default::default()],
            ..RangeFinder::default()
        };
        let bytes = cdr::to_vec(&scan);
        recorder
            .write(&Sample {
                channel,
                seq: u64::from(k),
                publish_time_ns: time_ns,
                log_time_ns: time_ns,
                data: &bytes,
            })
            .unwrap();
        all.push(bytes);
    }
    recorder.close().unwrap();
    all
}

/// Keys from a socket: ` ` pause/resume, `s` step, `q` quit.
struct SocketKeys(UnixStream);

impl Controls for SocketKeys {
    fn fd(&self) -> Option<BorrowedFd<'_>> {
        Some(self.0.as_fd())
    }

    fn take(&mut self) -> Vec<PlayCommand> {
        let mut buffer = [0u8; 16];
        let read = self.0.read(&mut buffer).unwrap_or(0);
        buffer[..read]
            .iter()
            .filter_map(|k| match k {
                b' ' => Some(PlayCommand::TogglePause),
                b's' => Some(PlayCommand::Step),
                b'q' => Some(PlayCommand::Quit),
                _ => None,
            })
            .collect()
    }
}

/// Runs a paused playback of `file` in a thread, with keys from the returned socket.
fn start(file: &Path, namespace: &Namespace) -> (UnixStream, std::thread::JoinHandle<PlayReport>) {
    let (keys, ours) = UnixStream::pair().unwrap();
    keys.set_nonblocking(true).unwrap();
    let mut options = PlayOptions::new(vec![file.to_path_buf()]);
    options.paused = true;
    options.rate = 1000.0;
    let namespace = namespace.clone();
    let player = std::thread::spawn(move || {
        let ipc = Ipc::open(&namespace, "player").unwrap();
        let stop = StopSignals::install().unwrap();
        play(&options, &ipc, &stop, &mut SocketKeys(keys), &mut |_| {}).unwrap()
    });
    (ours, player)
}

/// The next sample on `subscriber` (watchdog).
fn next(subscriber: &mut Subscriber) -> Vec<u8> {
    let deadline = Instant::now() + WATCHDOG;
    loop {
        if let Some(sample) = subscriber.receive().unwrap() {
            return sample.bytes().to_vec();
        }
        assert!(Instant::now() < deadline, "no sample came");
        WaitSet::new(WakeMode::Event)
            .wait(&[&*subscriber], Some(deadline))
            .unwrap();
    }
}

fn published(report: &PlayReport) -> BTreeMap<&str, u64> {
    report
        .topics
        .iter()
        .map(|(t, c)| (t.as_str(), c.published))
        .collect()
}

#[test]
fn a_paused_playback_publishes_one_message_per_step_until_quit() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("run.mcap");
    let scans = recording(&file);
    let namespace = Namespace::unique("play-step");
    let ipc = Ipc::open(&namespace, "test").unwrap();
    let mut subscriber = ipc
        .subscriber(TOPIC, &names::channel_config(TOPIC))
        .unwrap();
    let (mut keys, player) = start(&file, &namespace);
    for scan in &scans[..2] {
        keys.write_all(b"s").unwrap();
        assert_eq!(&next(&mut subscriber), scan);
    }
    keys.write_all(b"q").unwrap();
    let report = player.join().unwrap();
    assert!(report.stopped);
    assert_eq!(published(&report), BTreeMap::from([(TOPIC, 2)]));
}

#[test]
fn a_paused_playback_plays_to_its_end_once_resumed() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("run.mcap");
    let scans = recording(&file);
    let namespace = Namespace::unique("play-resume");
    let ipc = Ipc::open(&namespace, "test").unwrap();
    let mut subscriber = ipc
        .subscriber(TOPIC, &names::channel_config(TOPIC))
        .unwrap();
    let (mut keys, player) = start(&file, &namespace);
    keys.write_all(b" ").unwrap();
    for scan in &scans {
        assert_eq!(&next(&mut subscriber), scan);
    }
    let report = player.join().unwrap();
    assert!(!report.stopped);
    assert_eq!(published(&report), BTreeMap::from([(TOPIC, 5)]));
    assert_eq!(subscriber.lost(), 0);
}

#[test]
fn options_that_do_not_fit_the_recording_are_refused_with_the_reason() {
    let dir = tempfile::tempdir().unwrap();
    let file = dir.path().join("run.mcap");
    recording(&file);
    let namespace = Namespace::unique("play-options");
    let ipc = Ipc::open(&namespace, "test").unwrap();
    let stop = StopSignals::install().unwrap();
    let check = |edit: &dyn Fn(&mut PlayOptions), expected: &str| {
        let mut options = PlayOptions::new(vec![file.clone()]);
        edit(&mut options);
        let error = play(
            &options,
            &ipc,
            &stop,
            &mut lewis_recording::play::NoControls,
            &mut |_| {},
        )
        .unwrap_err()
        .to_string();
        assert!(error.contains(expected), "{error}");
    };
    check(&|o| o.rate = 0.0, "--rate 0: give a positive rate");
    check(
        &|o| o.start_s = 10.0,
        "--start 10: the recording lasts 4.000 s",
    );
    check(
        &|o| o.topics = vec!["/sonar/*".into()],
        "no topic of the recording matches --topics /sonar/*; it has: /laser/RangeFinder",
    );
}
