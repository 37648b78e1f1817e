//! `lewis up` records by default, and `lewis record` records a running robot: every file
//! (zstd, lz4, none, rotated) is decoded by the independent Python readers, passes
//! `pymcap-cli doctor`, and holds every sample the services published, byte for byte.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::record_common;

use std::ffi::OsStr;
use std::path::PathBuf;

use lewis_interfaces::msg::{
    Broker, CommandLog, LogLine, RangeFinder, RangeFinderGetGeometry, UnansweredCall,
};
use lewis_interfaces::{Message, cdr};
use lewis_runtime::client::Client;
use lewis_runtime::ipc::{Namespace, WaitSet, WakeMode};
use lewis_tests::{Up, WATCHDOG, doctor, open_ipc};
use record_common::{
    RecordProcess, Recording, assert_every_run_complete, assert_python_agrees, decode,
    test_robot_file,
};

/// The samples a client received, as the bytes they travelled as, by sequence number.
fn receive(client: &mut Client<RangeFinder>, count: usize) -> Vec<(u64, Vec<u8>)> {
    let mut got = Vec::new();
    while got.len() < count {
        let sample = client
            .recv_timeout(WATCHDOG)
            .unwrap()
            .expect("samples keep coming");
        let seq = sample.message.header().seq;
        got.push((seq, cdr::to_vec(&sample.message)));
    }
    got
}

#[test]
fn lewis_up_and_lewis_record_write_files_every_reader_decodes_with_every_sample() {
    let dir = tempfile::tempdir().unwrap();
    let namespace = Namespace::unique("record-up");
    let robot_path = dir.path().join("robot.toml");
    std::fs::write(&robot_path, test_robot_file()).unwrap();
    // Two more recorders beside the one of `lewis up`, subscribed before it starts.
    let lz4_split = dir.path().join("lz4.mcap");
    let none_split = dir.path().join("none.mcap");
    let lz4 = RecordProcess::start(
        &namespace,
        &[
            OsStr::new("--robot"),
            robot_path.as_os_str(),
            OsStr::new("-o"),
            lz4_split.as_os_str(),
            OsStr::new("--compression"),
            OsStr::new("lz4"),
            OsStr::new("--split-size"),
            OsStr::new("60000"),
        ],
    );
    let none = RecordProcess::start(
        &namespace,
        &[
            OsStr::new("--robot"),
            robot_path.as_os_str(),
            OsStr::new("-o"),
            none_split.as_os_str(),
            OsStr::new("--compression"),
            OsStr::new("none"),
            OsStr::new("--split-duration"),
            OsStr::new("500ms"),
        ],
    );
    let zstd = dir.path().join("run.mcap");
    let mut up = Up::start_with(
        tempfile::tempdir().unwrap(),
        namespace.clone(),
        &test_robot_file(),
        &[OsStr::new("-o"), zstd.as_os_str()],
    );
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut client = Client::<RangeFinder>::connect(&ipc, "app").unwrap();
    let received = receive(&mut client, 40);
    for _ in 0..2 {
        let geometry = client
            .call(&RangeFinderGetGeometry::default(), WATCHDOG)
            .unwrap();
        assert_eq!(geometry.header.provider, "laser");
    }
    let received_more = receive(&mut client, 10);
    drop(client);
    assert!(up.stop().success(), "{}", up.log());
    assert!(up.log().contains("recording closed"), "{}", up.log());
    let (ok, out) = lz4.stop();
    assert!(ok, "{out}");
    let (ok, out) = none.stop();
    assert!(ok, "{out}");

    let parts = |path: &PathBuf| -> Vec<PathBuf> {
        let index_path = lewis_recorder::index::index_path(path);
        let index = lewis_recorder::index::PartsIndex::read(&index_path).unwrap();
        assert!(index.parts.iter().all(|p| p.complete), "{index:?}");
        index.part_paths(&index_path)
    };
    let runs = [
        ("zstd", vec![zstd.clone()]),
        ("lz4", parts(&lz4_split)),
        ("none", parts(&none_split)),
    ];
    assert!(runs[1].1.len() > 1, "lz4 recording was not split");
    assert!(runs[2].1.len() > 1, "none recording was not split");
    let mut laser_counts = Vec::new();
    for (compression, files) in &runs {
        for file in files {
            doctor(file);
        }
        let recording = Recording::read(files);
        assert_python_agrees(files, &recording);
        for topic in [
            "/laser/RangeFinder",
            "/laser/Distance",
            "/lewis/health/laser",
        ] {
            assert_every_run_complete(&recording, topic);
            assert_eq!(recording.seq_runs(topic).len(), 1, "{compression} {topic}");
        }
        let laser = recording.of("/laser/RangeFinder");
        for (seq, bytes) in received.iter().chain(&received_more) {
            let recorded = laser
                .iter()
                .find(|m| m.seq == *seq)
                .unwrap_or_else(|| panic!("{compression}: sample {seq} is not in the file"));
            assert_eq!(&recorded.data, bytes, "{compression}: sample {seq} differs");
        }
        let commands: Vec<CommandLog> = recording
            .of("/lewis/commands/laser")
            .iter()
            .map(decode)
            .collect();
        assert_eq!(commands.len(), 2, "{compression}");
        for command in &commands {
            assert_eq!(
                (
                    command.interface.as_str(),
                    command.command.as_str(),
                    command.status.as_str()
                ),
                ("RangeFinder", "get_geometry", "ok")
            );
            assert!(!command.reply.is_empty());
        }
        let decisions: Vec<Broker> = recording.of("/lewis/broker").iter().map(decode).collect();
        assert!(
            decisions
                .iter()
                .any(|d| d.action == "bind" && d.client == "app" && d.service == "laser"),
            "{compression}: {decisions:?}"
        );
        assert!(
            recording.loss().values().all(|&lost| lost == 0),
            "{compression}"
        );
        assert!(
            recording.metadata[lewis_recorder::ROBOT_METADATA].contains_key("robot.toml"),
            "{compression}"
        );
        assert!(
            recording.metadata[lewis_recorder::INTERFACES_METADATA].contains_key("RangeFinder.xml")
        );
        assert_eq!(
            recording.channels["/laser/RangeFinder"]["provider"], "laser",
            "{compression}"
        );
        laser_counts.push(laser.len());
    }
    // The three recorders saw the same run.
    assert!(
        laser_counts.windows(2).all(|w| w[0] == w[1]),
        "{laser_counts:?}"
    );
}

/// The answering side logs nothing of a call its provider never answered: the caller records
/// it on `/lewis/calls`, with its request, provider, timeout and why.
#[test]
fn a_call_its_provider_never_answers_is_recorded_by_the_caller() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("calls.mcap");
    let mut up = Up::start_with(
        tempfile::tempdir().unwrap(),
        Namespace::unique("record-calls"),
        &test_robot_file(),
        &[OsStr::new("-o"), output.as_os_str()],
    );
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut client = Client::<RangeFinder>::connect(&ipc, "app").unwrap();
    receive(&mut client, 2);
    // Stalled, the laser answers nothing; killed while the call waits, it never will.
    let lewis = |args: &[&str]| {
        let output = std::process::Command::new(lewis_tests::lewis_exe())
            .args(args)
            .args(["--namespace", up.namespace.as_str(), "--timeout", "10"])
            .output()
            .unwrap();
        assert!(output.status.success(), "{args:?}: {output:?}");
    };
    lewis(&["fault", "laser", "--stall"]);
    let timeout = std::time::Duration::from_millis(800);
    let command = RangeFinderGetGeometry::default();
    let frame = lewis_service::wire::request_to_vec("get_geometry", &cdr::to_vec(&command));
    let raw = client.raw_mut();
    let call = raw.call(&frame, timeout).unwrap();
    lewis(&["fault", "laser", "--kill"]);
    let waits = WaitSet::new(WakeMode::Event);
    let outcome = loop {
        if let Some(outcome) = raw.take_call_outcome() {
            break outcome;
        }
        waits
            .wait(&raw.waitables(), Some(std::time::Instant::now() + WATCHDOG))
            .unwrap();
    };
    assert_eq!(outcome.call, call);
    let Err(err) = outcome.result else {
        panic!("a dead provider never answers")
    };
    assert!(err.to_string().contains("no reply"), "{err}");
    drop(client);
    assert!(up.stop().success(), "{}", up.log());

    let recording = Recording::read(std::slice::from_ref(&output));
    let calls: Vec<UnansweredCall> = recording.of("/lewis/calls").iter().map(decode).collect();
    let [call] = &calls[..] else {
        panic!("one unanswered call expected: {calls:?}");
    };
    assert_eq!(
        (
            call.client.as_str(),
            call.interface.as_str(),
            call.command.as_str(),
            call.provider.as_str(),
            call.status.as_str(),
            call.timeout_ns,
        ),
        (
            "app",
            "RangeFinder",
            "get_geometry",
            "laser",
            "timed-out",
            800_000_000
        )
    );
    assert_eq!(call.request, cdr::to_vec(&command));
    assert_eq!(call.header().provider, "app");
    assert!(
        call.header().publish_time_ns >= call.sent_ns + call.timeout_ns,
        "{call:?}"
    );
    assert_eq!(recording.channels["/lewis/calls"]["kind"], "calls");
    // The laser answered none: its own log has nothing of it.
    assert!(recording.of("/lewis/commands/laser").is_empty());
}

/// The broker measures what each service's process uses of the CPU, hands it to its core
/// and publishes it; the recording keeps it, so replay decides with the same numbers.
#[test]
fn the_cpu_the_broker_measured_is_recorded() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("cpu.mcap");
    let mut up = Up::start_with(
        tempfile::tempdir().unwrap(),
        Namespace::unique("record-cpu"),
        &test_robot_file(),
        &[OsStr::new("-o"), output.as_os_str()],
    );
    up.wait_line("broker up");
    let ipc = open_ipc(&up.namespace, "test-app");
    let mut measured = ipc
        .subscriber(
            lewis_runtime::names::CPU_CHANNEL,
            &lewis_runtime::names::cpu_config(),
        )
        .unwrap();
    let mut client = Client::<RangeFinder>::connect(&ipc, "app").unwrap();
    receive(&mut client, 2);
    // The laser runs; its first measurement comes a second after its first look.
    let waits = WaitSet::new(WakeMode::Event);
    let deadline = std::time::Instant::now() + WATCHDOG;
    let seen = loop {
        if let Some(sample) = measured.receive().unwrap() {
            let message: lewis_interfaces::msg::ProcessCpu =
                cdr::from_bytes(sample.bytes()).unwrap();
            if message.service == "laser" {
                break message;
            }
            continue;
        }
        assert!(
            std::time::Instant::now() < deadline,
            "no CPU measurement of the laser"
        );
        waits.wait(&[&measured], Some(deadline)).unwrap();
    };
    // A test service at 50 Hz uses a little of one core.
    assert!((0..1000).contains(&seen.milli_cores), "{seen:?}");
    drop(client);
    assert!(up.stop().success(), "{}", up.log());
    let recording = Recording::read(std::slice::from_ref(&output));
    let recorded: Vec<lewis_interfaces::msg::ProcessCpu> = recording
        .of("/lewis/broker/cpu")
        .iter()
        .map(decode)
        .collect();
    assert!(recorded.contains(&seen), "{recorded:?}");
    assert_eq!(recording.channels["/lewis/broker/cpu"]["kind"], "cpu");
}

/// A service that only talks: its output lines go to `/lewis/log`.
const TALKER: &str = r#"
[robot]
name = "talk"

[[services]]
name = "talker"
command = ["/bin/sh", "-c", "echo hello from the talker; exec sleep 60"]
start = "always"
heartbeat_deadline_ms = 60000
provides = [{ interface = "Distance", quality = 1, cost = 1 }]
"#;

#[test]
fn service_output_lines_are_recorded_with_the_time_they_were_published() {
    let dir = tempfile::tempdir().unwrap();
    let output = dir.path().join("talk.mcap");
    let mut up = Up::start_with(
        tempfile::tempdir().unwrap(),
        Namespace::unique("record-log"),
        TALKER,
        &[OsStr::new("-o"), output.as_os_str()],
    );
    up.wait_line("hello from the talker");
    assert!(up.stop().success(), "{}", up.log());
    let recording = Recording::read(std::slice::from_ref(&output));
    let lines: Vec<(LogLine, &record_common::Recorded)> = recording
        .of("/lewis/log")
        .iter()
        .map(|m| (decode(m), m))
        .collect();
    let (line, recorded) = lines
        .iter()
        .find(|(l, _)| l.text == "hello from the talker")
        .unwrap_or_else(|| panic!("the talker's line is not on /lewis/log: {lines:?}"));
    assert_eq!(
        (line.service.as_str(), line.stream.as_str()),
        ("talker", "stdout")
    );
    // MCAP publish time = the header's, stamped when the broker published the line
    // (before the recorder received it); it used to be 0.
    assert_eq!(
        recorded.publish_time_ns,
        u64::try_from(line.header.publish_time_ns).unwrap()
    );
    assert!(
        recorded.publish_time_ns > 0 && recorded.publish_time_ns <= recorded.log_time_ns,
        "publish time {} received {}",
        recorded.publish_time_ns,
        recorded.log_time_ns
    );
}
