//! `lewis play`: a real process publishing a recording (a short import of the real
//! freiburg-079 log) into live IPC, received by subscribers in this test byte for byte and
//! in order with its clock, and recorded again by a real `lewis record`.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::record_common;

use std::collections::BTreeMap;
use std::path::Path;
use std::process::{Child, Command, Stdio};
use std::time::Instant;

use lewis_interfaces::cdr;
use lewis_interfaces::msg::Clock;
use lewis_runtime::ipc::{Namespace, Subscriber, WaitSet, WakeMode};
use lewis_runtime::names;
use lewis_tests::{WATCHDOG, lewis_exe, open_ipc, run_ok, shared_data, wait_child};
use record_common::{RecordProcess, Recording};

/// Imports the first `scans` scans of freiburg-079 into `dir/f.mcap`.
fn import(dir: &Path, scans: u32) -> std::path::PathBuf {
    let log = shared_data("carmen/freiburg-079-corrected.log.gz");
    let out = dir.join("f.mcap");
    let _ = run_ok(
        Command::new(lewis_exe())
            .args(["import", "carmen"])
            .arg(log)
            .arg("-o")
            .arg(&out)
            .args(["--limit-scans", &scans.to_string()]),
    );
    out
}

/// Starts `lewis play FILE --namespace NS ARGS...` with no terminal.
fn play(file: &Path, namespace: &Namespace, args: &[&str]) -> Child {
    Command::new(lewis_exe())
        .arg("play")
        .arg(file)
        .args(["--namespace", namespace.as_str()])
        .args(args)
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lewis play starts")
}

/// Waits (watchdog) for `child` to end with 0, and returns its stdout.
fn finish(mut child: Child) -> String {
    let status = wait_child(&mut child);
    let output = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout).into_owned();
    assert!(
        status.success(),
        "lewis play failed ({status}):\n{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    stdout
}

#[test]
fn a_played_recording_reaches_live_subscribers_byte_for_byte_in_order_with_its_clock() {
    let dir = tempfile::tempdir().unwrap();
    let file = import(dir.path(), 10);
    let recorded = Recording::read(std::slice::from_ref(&file));
    let namespace = Namespace::unique("play");
    let ipc = open_ipc(&namespace, "test-subscriber");
    let topics = [
        "/laser/RangeFinder",
        "/base/Egomotion",
        names::CLOCK_CHANNEL,
    ];
    // Subscribed before the player starts: nothing it publishes is missed.
    let mut subscribers: Vec<Subscriber> = topics
        .iter()
        .map(|t| ipc.subscriber(t, &names::channel_config(t)).unwrap())
        .collect();
    let started = Instant::now();
    let child = play(&file, &namespace, &["--rate", "2"]);

    let expected = |topic: &str| -> Vec<Vec<u8>> {
        recorded.of(topic).iter().map(|m| m.data.clone()).collect()
    };
    let want: BTreeMap<&str, Vec<Vec<u8>>> =
        topics[..2].iter().map(|t| (*t, expected(t))).collect();
    let mut got: BTreeMap<&str, Vec<Vec<u8>>> = BTreeMap::new();
    let mut clock: Vec<Clock> = Vec::new();
    let waits = WaitSet::new(WakeMode::Event);
    let done = |got: &BTreeMap<&str, Vec<Vec<u8>>>| {
        want.iter()
            .all(|(t, w)| got.get(t).map_or(0, Vec::len) >= w.len())
    };
    while !done(&got) {
        assert!(
            started.elapsed() < WATCHDOG,
            "only {:?} of {:?} messages arrived",
            got.iter().map(|(t, m)| (t, m.len())).collect::<Vec<_>>(),
            want.iter().map(|(t, m)| (t, m.len())).collect::<Vec<_>>()
        );
        let sources: Vec<&dyn lewis_runtime::ipc::Waitable> =
            subscribers.iter().map(|s| s as _).collect();
        waits
            .wait(&sources, Some(Instant::now() + WATCHDOG))
            .unwrap();
        for (topic, subscriber) in topics.iter().zip(&mut subscribers) {
            while let Some(sample) = subscriber.receive().unwrap() {
                if *topic == names::CLOCK_CHANNEL {
                    clock.push(cdr::from_bytes(sample.bytes()).unwrap());
                } else {
                    got.entry(topic).or_default().push(sample.bytes().to_vec());
                }
            }
        }
    }
    let stdout = finish(child);
    assert!(stdout.contains("played "), "{stdout}");
    for (topic, messages) in &want {
        assert!(got[topic] == *messages, "{topic}: other bytes or order");
        assert_eq!(
            subscribers[topics.iter().position(|t| t == topic).unwrap()].lost(),
            0
        );
    }
    // The clock: the recording's log time, never backwards, at the rate asked, ending at
    // the last message's time (kept as the channel's history).
    let clock_sub = &mut subscribers[2];
    while let Some(sample) = clock_sub.receive().unwrap() {
        clock.push(cdr::from_bytes(sample.bytes()).unwrap());
    }
    assert!(clock.len() >= 2, "{clock:?}");
    assert!(clock.windows(2).all(|w| w[0].time_ns <= w[1].time_ns));
    assert!(clock.iter().all(|c| c.rate == 2.0));
    // Paused only at the end: the time stands there for the services that follow it.
    let (end, playing) = clock.split_last().unwrap();
    assert!(end.paused && playing.iter().all(|c| !c.paused), "{clock:?}");
    let last_log = recorded
        .topics
        .values()
        .flatten()
        .map(|m| m.log_time_ns)
        .max()
        .unwrap();
    assert_eq!(
        u64::try_from(clock.last().unwrap().time_ns).unwrap(),
        last_log
    );
}

#[test]
fn lewis_record_records_a_played_recording_with_the_bytes_it_was_recorded_with() {
    let dir = tempfile::tempdir().unwrap();
    let file = import(dir.path(), 12);
    let recorded = Recording::read(std::slice::from_ref(&file));
    let (name, toml) = recorded.metadata[lewis_recorder::ROBOT_METADATA]
        .iter()
        .next()
        .unwrap();
    let robot = dir.path().join(name);
    std::fs::write(&robot, toml).unwrap();
    let namespace = Namespace::unique("play-record");
    let again = dir.path().join("again.mcap");
    let recorder = RecordProcess::start(
        &namespace,
        &[
            "--robot".as_ref(),
            robot.as_os_str(),
            "-o".as_ref(),
            again.as_os_str(),
        ],
    );
    finish(play(&file, &namespace, &["--rate", "4"]));
    let (ok, output) = recorder.stop();
    assert!(ok, "{output}");

    let replayed = Recording::read(&[again]);
    for topic in [
        "/laser/RangeFinder",
        "/distance/Distance",
        "/sonar/RangeFinder",
        "/base/Egomotion",
        "/lewis/health/laser",
    ] {
        let before: Vec<(&[u8], u64)> = recorded
            .of(topic)
            .iter()
            .map(|m| (m.data.as_slice(), m.publish_time_ns))
            .collect();
        let after: Vec<(&[u8], u64)> = replayed
            .of(topic)
            .iter()
            .map(|m| (m.data.as_slice(), m.publish_time_ns))
            .collect();
        assert!(!before.is_empty());
        assert!(
            before == after,
            "{topic}: {} recorded, {} recorded again, or other bytes",
            before.len(),
            after.len()
        );
    }
}

#[test]
fn the_terminals_keys_step_and_resume_a_paused_playback() {
    let dir = tempfile::tempdir().unwrap();
    let file = import(dir.path(), 6);
    let recorded = Recording::read(std::slice::from_ref(&file));
    let scans: Vec<&[u8]> = recorded
        .of("/laser/RangeFinder")
        .iter()
        .map(|m| m.data.as_slice())
        .collect();
    let namespace = Namespace::unique("play-keys");
    let ipc = open_ipc(&namespace, "test-subscriber");
    let topic = "/laser/RangeFinder";
    let mut subscriber = ipc
        .subscriber(topic, &names::channel_config(topic))
        .unwrap();
    // The player's stdin is a real terminal: the slave side of a pseudo-terminal.
    let pty = nix::pty::openpty(None, None).unwrap();
    let mut child = Command::new(lewis_exe())
        .arg("play")
        .arg(&file)
        .args([
            "--namespace",
            namespace.as_str(),
            "--paused",
            "--rate",
            "20",
        ])
        .args(["--topics", topic])
        .stdin(Stdio::from(pty.slave.try_clone().unwrap()))
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .expect("lewis play starts");
    let mut keys = std::fs::File::from(pty.master);
    let mut next = || {
        let started = Instant::now();
        loop {
            if let Some(sample) = subscriber.receive().unwrap() {
                return sample.bytes().to_vec();
            }
            assert!(started.elapsed() < WATCHDOG, "no scan came");
            WaitSet::new(WakeMode::Event)
                .wait(&[&subscriber], Some(Instant::now() + WATCHDOG))
                .unwrap();
        }
    };
    // `s` publishes one scan at a time; each is awaited before the next key.
    for scan in &scans[..2] {
        std::io::Write::write_all(&mut keys, b"s").unwrap();
        assert_eq!(next(), *scan);
    }
    // Space resumes: the rest plays to the end.
    std::io::Write::write_all(&mut keys, b" ").unwrap();
    for scan in &scans[2..] {
        assert_eq!(next(), *scan);
    }
    let status = wait_child(&mut child);
    let output = child.wait_with_output().unwrap();
    let stdout = String::from_utf8_lossy(&output.stdout);
    assert!(
        status.success(),
        "{stdout}\n{}",
        String::from_utf8_lossy(&output.stderr)
    );
    assert!(
        stdout.contains(&format!("{topic}: {}", scans.len())),
        "{stdout}"
    );
    // The terminal is given back as it was: line by line, with echo.
    let mode = nix::sys::termios::tcgetattr(&pty.slave).unwrap();
    let line_mode = nix::sys::termios::LocalFlags::ICANON | nix::sys::termios::LocalFlags::ECHO;
    assert!(
        mode.local_flags.contains(line_mode),
        "{:?}",
        mode.local_flags
    );
}

/// A synthetic laser named `sensor` (its channel is not one the player publishes), ticking
/// at 20 Hz.
const TICKING: &str = r#"
[robot]
name = "ticking"

[[services]]
name = "sensor"
kind = "test-range"
start = "always"
provides = [{ interface = "RangeFinder", quality = 1, cost = 1 }]

[services.parameters]
beams = 8
rate_hz = 20.0
seed = 1
"#;

#[test]
fn a_live_service_on_the_played_clock_ticks_and_stamps_in_the_recordings_time() {
    let dir = tempfile::tempdir().unwrap();
    let file = import(dir.path(), 60);
    let robot = dir.path().join("ticking.toml");
    std::fs::write(&robot, TICKING).unwrap();
    let namespace = Namespace::unique("play-clock");
    let ipc = open_ipc(&namespace, "test-subscriber");
    let mut scans = ipc
        .subscriber(
            "/sensor/RangeFinder",
            &names::channel_config("/sensor/RangeFinder"),
        )
        .unwrap();
    let recorded = Recording::read(std::slice::from_ref(&file));
    let log_times = recorded
        .topics
        .values()
        .flatten()
        .map(|m| i64::try_from(m.log_time_ns).unwrap());
    let (first, last) = (log_times.clone().min().unwrap(), log_times.max().unwrap());
    assert!(
        last - first > 2_000_000_000,
        "a short recording: {first}..{last}"
    );
    let mut service = Command::new(lewis_exe())
        .args(["service", "sensor", "--robot"])
        .arg(&robot)
        .args(["--namespace", namespace.as_str(), "--clock", "played"])
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    // Its node is up before the player starts (a clock sample it meets late is kept for
    // it as the channel's history).
    let _pid = lewis_tests::wait_node(&ipc, "sensor", None);
    let mut player = play(&file, &namespace, &["--rate", "4", "--topics", "/base/*"]);
    let mut stamps: Vec<i64> = Vec::new();
    let waits = WaitSet::new(WakeMode::Event);
    let started = Instant::now();
    // Scans are taken as they come (the channel keeps only a few) until the player ends;
    // the short deadline is for looking at the player, which has no descriptor here.
    let ended = loop {
        if let Some(status) = player.try_wait().unwrap() {
            break status;
        }
        assert!(started.elapsed() < WATCHDOG, "the player did not end");
        waits
            .wait(
                &[&scans as &dyn lewis_runtime::ipc::Waitable],
                Some(Instant::now() + std::time::Duration::from_millis(20)),
            )
            .unwrap();
        while let Some(sample) = scans.receive().unwrap() {
            let scan: lewis_interfaces::msg::RangeFinder = cdr::from_bytes(sample.bytes()).unwrap();
            stamps.push(scan.header.publish_time_ns);
        }
    };
    let output = player.wait_with_output().unwrap();
    assert!(
        ended.success(),
        "lewis play failed ({ended}): {}",
        String::from_utf8_lossy(&output.stderr)
    );
    lewis_tests::signal(service.id(), nix::sys::signal::Signal::SIGTERM);
    let status = wait_child(&mut service);
    assert!(status.success(), "lewis service: {status}");
    assert_eq!(scans.lost(), 0);
    // Stamped with the recording's time (the log is from 2003), never the machine's.
    assert!(
        stamps.iter().all(|t| (first..=last).contains(t)),
        "stamps {stamps:?} outside the played {first}..{last}"
    );
    assert!(stamps.windows(2).all(|w| w[0] < w[1]), "{stamps:?}");
    // Ticks every 50 ms of played time: at rate 4 a service on the machine's clock would
    // stamp its ticks 200 ms of played time apart.
    let mut gaps: Vec<i64> = stamps.windows(2).map(|w| w[1] - w[0]).collect();
    assert!(gaps.len() >= 10, "{stamps:?}");
    gaps.sort_unstable();
    let median = gaps[gaps.len() / 2];
    assert!(
        (45_000_000..=110_000_000).contains(&median),
        "median gap {median} ns: {gaps:?}"
    );
}
