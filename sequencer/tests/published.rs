//! A mission run by `lewis seq run` (a real process) is published on `/lewis/sequencer`
//! through the runtime's IPC: a subscriber receives every record, and an MCAP recording of
//! those messages (written with the recorder library) replays identically with
//! `lewis seq replay`, or shows where a changed script decides differently.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use std::path::{Path, PathBuf};
use std::process::{Child, Command, Output, Stdio};
use std::time::Instant;

use common::{TESTPROG, show};
use lewis_interfaces::cdr;
use lewis_interfaces::msg::Sequencer as SequencerMessage;
use lewis_recorder::{ChannelSpec, Recorder, RecorderOptions, Sample};
use lewis_runtime::ipc::{Ipc, Namespace, WaitSet, WakeMode, Woken};
use lewis_runtime::names::{SEQUENCER_CHANNEL, sequencer_config};
use lewis_sequencer::record::{Entry, Record};
use lewis_sequencer::{Decision, from_message, read_json_lines};
use lewis_testkit::{WATCHDOG, lewis_exe, wait_child};

/// The paper's mission without `use gui`: a crash beyond the restart limit and an unlisted
/// exit code both lead to recovery, which ends the mission at `stop`.
const MISSION: &str = "\
start door
restart 3
recovery oops

state door {P} exit:0
  action 0 trans sign

state sign {P} --runs {D}/sign.runs exit:0 exit:1
  action 0 trans sign
  action 1 trans queue

state queue {P} --runs {D}/queue.runs signal:SEGV signal:SEGV signal:SEGV signal:SEGV exit:0
  action 0 trans register

state register {P} exit:7
  action 0 trans stop

state oops {P} print:recovering exit:0
  action 0 trans stop
";

/// What the mission decides, as `show` prints it.
const EXPECTED: &str = "\
mission door sign queue register oops
run door #1
> exit code 0
transition door -> sign on 0
run sign #1
> exit code 0
transition sign -> sign on 0
run sign #1
> exit code 1
transition sign -> queue on 1
run queue #1
> signal 11
restart queue attempt 2
run queue #2
> signal 11
restart queue attempt 3
run queue #3
> signal 11
restart queue attempt 4
run queue #4
> signal 11
recover from queue
run oops #1
> exit code 0
transition oops -> stop on 0
finished
";

/// One message as it travelled on the channel.
struct Travelled {
    bytes: Vec<u8>,
    record: Record,
}

/// Runs the mission with `lewis seq run` in a fresh namespace while a subscriber listens
/// on `/lewis/sequencer`; returns what the subscriber received and the records the same
/// process wrote with `--events`.
fn run_published(dir: &Path) -> (Vec<Travelled>, Vec<Record>) {
    let script = dir.join("mission.seq");
    std::fs::write(
        &script,
        MISSION
            .replace("{P}", TESTPROG)
            .replace("{D}", &dir.display().to_string()),
    )
    .unwrap();
    let namespace = Namespace::unique("seq-pub");
    let ipc = Ipc::open(&namespace, "test-subscriber").unwrap();
    let mut subscriber = ipc
        .subscriber(SEQUENCER_CHANNEL, &sequencer_config())
        .unwrap();
    let events = dir.join("events.jsonl");
    let mut child = Command::new(lewis_exe())
        .args(["seq", "run", "--namespace", namespace.as_str(), "--events"])
        .arg(&events)
        .arg(&script)
        .stdin(Stdio::null())
        .stdout(Stdio::null())
        .stderr(Stdio::null())
        .spawn()
        .unwrap();
    let waits = WaitSet::new(WakeMode::Event);
    let mut received = Vec::new();
    let finished = |r: &Record| {
        matches!(
            r.entry,
            Entry::Decided {
                decision: Decision::Finished { .. } | Decision::Aborted { .. }
            }
        )
    };
    while !received
        .last()
        .is_some_and(|t: &Travelled| finished(&t.record))
    {
        let woken = waits
            .wait(&[&subscriber], Some(Instant::now() + WATCHDOG))
            .unwrap();
        assert!(
            !matches!(woken, Woken::DeadlineReached),
            "no record within {WATCHDOG:?}; received so far:\n{}",
            show_travelled(&received)
        );
        while let Some(sample) = subscriber.receive().unwrap() {
            let bytes = sample.bytes().to_vec();
            let message: SequencerMessage = cdr::from_bytes(&bytes).unwrap();
            let record = from_message(&message).unwrap();
            received.push(Travelled { bytes, record });
        }
    }
    let status = wait_child(&mut child);
    // The mission reaches `stop` through recovery: a failure since issue 20 (the mission
    // succeeds only when its task is done), so `lewis seq run` exits with 1.
    assert_eq!(status.code(), Some(1), "lewis seq run: {status}");
    assert_eq!(subscriber.lost(), 0, "the subscriber missed records");
    let written = read_json_lines(std::io::BufReader::new(
        std::fs::File::open(&events).unwrap(),
    ))
    .unwrap();
    (received, written)
}

fn show_travelled(received: &[Travelled]) -> String {
    let records: Vec<Record> = received.iter().map(|t| t.record.clone()).collect();
    show(&records)
}

/// Writes what travelled into an MCAP file, as the live recorder would.
fn record_mcap(path: &Path, received: &[Travelled]) {
    let mut recorder = Recorder::create(RecorderOptions::new(path)).unwrap();
    let interface = lewis_interfaces::interface_info("Sequencer").unwrap();
    let channel = recorder
        .add_channel(ChannelSpec::publication(
            interface,
            lewis_sequencer::message::PROVIDER,
            SEQUENCER_CHANNEL,
        ))
        .unwrap();
    for (index, travelled) in received.iter().enumerate() {
        let time_ns = travelled.record.time_ns;
        recorder
            .write(&Sample {
                channel,
                seq: travelled.record.seq + 1,
                publish_time_ns: time_ns,
                log_time_ns: time_ns + i64::try_from(index).unwrap(),
                data: &travelled.bytes,
            })
            .unwrap();
    }
    recorder.close().unwrap();
}

fn lewis(args: &[&str], paths: &[&Path]) -> Output {
    let mut command = Command::new(lewis_exe());
    command.args(args).args(paths);
    let child: Child = command
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(Stdio::piped())
        .spawn()
        .unwrap();
    child.wait_with_output().unwrap()
}

fn text(output: &Output) -> String {
    format!(
        "{}{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    )
}

#[test]
fn a_published_mission_reaches_a_subscriber_with_every_record() {
    let dir = tempfile::tempdir().unwrap();
    let (received, written) = run_published(dir.path());
    let records: Vec<Record> = received.iter().map(|t| t.record.clone()).collect();
    assert_eq!(show(&records), EXPECTED);
    // Every record, and nothing else, in order: the same as the process wrote to its file.
    assert_eq!(records, written);
    let numbers: Vec<u64> = records.iter().map(|r| r.seq).collect();
    assert_eq!(numbers, (0..records.len() as u64).collect::<Vec<_>>());
}

#[test]
fn a_recorded_mcap_replays_identically_and_shows_where_a_changed_script_differs() {
    let dir = tempfile::tempdir().unwrap();
    let (received, _) = run_published(dir.path());
    let mcap = dir.path().join("run.mcap");
    record_mcap(&mcap, &received);

    let same = lewis(&["seq", "replay"], &[&mcap]);
    assert_eq!(same.status.code(), Some(0), "{}", text(&same));
    assert!(
        text(&same).ends_with(&format!(
            "{}: 8 events and 17 decisions replayed on {}: identical\n",
            mcap.display(),
            dir.path().join("mission.seq").display()
        )),
        "{}",
        text(&same)
    );

    // The queue now has one restart: its second crash goes to recovery.
    let changed: PathBuf = dir.path().join("changed.seq");
    let script = std::fs::read_to_string(dir.path().join("mission.seq")).unwrap();
    std::fs::write(&changed, script.replace("restart 3", "restart 1")).unwrap();
    let different = lewis(&["seq", "replay"], &[&mcap, &changed]);
    assert_eq!(different.status.code(), Some(1), "{}", text(&different));
    let expected = format!(
        "{}: 9 decisions identical, then {} decides differently after event 5 (signal 11), decision 1:\n  recorded: restart queue attempt 3 | `queue` was killed by signal 11; restart 2 of 3\n  script:   recover from queue | `queue` was killed by signal 11 after 1 restart\n",
        mcap.display(),
        changed.display()
    );
    let got = text(&different);
    assert!(
        got.contains(&expected),
        "expected:\n{expected}\ngot:\n{got}"
    );
}

#[test]
fn an_mcap_without_the_sequencer_channel_is_refused_with_a_hint() {
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("empty.mcap");
    Recorder::create(RecorderOptions::new(&path))
        .unwrap()
        .close()
        .unwrap();
    let output = lewis(&["seq", "replay"], &[&path]);
    assert_eq!(output.status.code(), Some(2), "{}", text(&output));
    assert!(
        text(&output).contains(&format!(
            "{} holds no /lewis/sequencer channel: was a mission running",
            path.display()
        )),
        "{}",
        text(&output)
    );
}
