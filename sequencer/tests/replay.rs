//! `lewis seq replay`: a live mission's records, written as JSON lines and read back,
//! replay identically on the same script and show the first difference on a changed one.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use crate::common;

use std::io::BufReader;
use std::path::Path;

use common::{PAPER, answering, run_live, write_script};
use expect_test::{Expect, expect};
use lewis_sequencer::record::{Entry, JsonLinesSink, Record};
use lewis_sequencer::replay::{ReadError, RecordingError};
use lewis_sequencer::{
    Decision, Event, MemorySources, Recording, TrustingResolver, check_with, compare,
    read_json_lines,
};

/// Runs the paper's mission live, recording to a JSON-lines file; returns what the channel
/// saw and what the file holds.
fn record_the_papers_mission(dir: &Path) -> (Vec<Record>, Vec<Record>) {
    let (script, mission) = write_script(dir, PAPER);
    let events = dir.join("events.jsonl");
    let mut file = JsonLinesSink::create(&events).unwrap();
    let (_, seen) = run_live(
        &script,
        mission,
        |o| o,
        Some(&mut file),
        &mut answering(&["queue", "register"]),
    );
    file.finish().unwrap();
    let read = read_json_lines(BufReader::new(std::fs::File::open(&events).unwrap())).unwrap();
    (seen, read)
}

/// Replays `recording` on the paper's script changed by `change` and shows the result,
/// with the temp folder as `DIR`.
fn check_replay(dir: &Path, recording: &Recording, change: (&str, &str), expected: &Expect) {
    let (_, mission) = write_script(dir, &PAPER.replace(change.0, change.1));
    let comparison = compare(mission, recording);
    let shown = match &comparison.difference {
        None => format!(
            "identical: {} steps, {} decisions",
            comparison.identical_steps, comparison.identical_decisions
        ),
        Some(difference) => format!(
            "{} decisions identical, then {difference}",
            comparison.identical_decisions
        ),
    };
    let shown = shown
        .replace(common::TESTPROG, "TESTPROG")
        .replace(&dir.display().to_string(), "DIR");
    expected.assert_eq(&shown);
}

#[test]
fn a_recorded_mission_replays_identically_and_shows_where_a_changed_script_differs() {
    let dir = tempfile::tempdir().unwrap();
    let (seen, read) = record_the_papers_mission(dir.path());
    assert_eq!(read, seen, "the JSON lines must hold every record exactly");
    let recording = Recording::from_records(&read).unwrap();
    assert_eq!(recording.script, dir.path().join("mission.seq"));

    check_replay(
        dir.path(),
        &recording,
        ("", ""),
        &expect!["identical: 16 steps, 29 decisions"],
    );
    check_replay(
        dir.path(),
        &recording,
        ("restart 3", "restart 2"),
        &expect![[r#"
            13 decisions identical, then after event 7 (signal 11), decision 1:
              recorded: restart queue attempt 4 | `queue` was killed by signal 11; restart 3 of 3
              script:   recover from queue | `queue` was killed by signal 11 after 2 restarts"#]],
    );
    check_replay(
        dir.path(),
        &recording,
        (
            "register.runs exit:7 exit:0\n  action 0 trans stop",
            "register.runs exit:7 exit:0\n  action 0 trans stop\n  action 7 trans door",
        ),
        &expect![[r#"
            22 decisions identical, then after event 12 (exit code 7), decision 1:
              recorded: recover from register | `register` exited with code 7, which the script does not list
              script:   transition register -> door on 7 | `register` exited with code 7, which leads to `door`"#]],
    );
    // A reworded reason is not a different decision; a different program is.
    check_replay(
        dir.path(),
        &recording,
        ("state door {P} exit:0", "state door {P} exit:0 --fast"),
        &expect![[r#"
            0 decisions identical, then at the start, decision 1:
              recorded: run door attempt 1: TESTPROG "exit:0" | the mission starts at `door`
              script:   run door attempt 1: TESTPROG "exit:0" "--fast" | the mission starts at `door`"#]],
    );
}

fn mission(script: &str) -> lewis_sequencer::Mission {
    let sources = MemorySources::new().with("m.seq", script);
    check_with(Path::new("m.seq"), &sources, &TrustingResolver)
        .unwrap_or_else(|d| panic!("{d}"))
        .mission
}

fn record(seq: u64, entry: Entry) -> Record {
    Record {
        seq,
        time_ns: 1_000 + i64::try_from(seq).unwrap(),
        entry,
    }
}

fn started() -> Entry {
    Entry::MissionStarted {
        script: "m.seq".into(),
        states: vec!["a".into()],
        use_gui: false,
        supervision: None,
    }
}

#[test]
fn a_script_that_decides_more_than_was_recorded_is_a_difference() {
    let with_gui = "start a\nrecovery r\nuse gui\nstate a x\n  action 0 trans stop\nstate r y\n  action 0 trans stop\n";
    let (_, start) =
        lewis_sequencer::Sequencer::start(mission(with_gui), lewis_sequencer::Supervision::Page);
    let mut records = vec![record(0, started())];
    records.extend(
        start
            .into_iter()
            .map(|decision| record(1, Entry::Decided { decision })),
    );
    records.push(record(
        2,
        Entry::Observed {
            event: Event::Exited { code: 0 },
        },
    ));
    records.push(record(
        3,
        Entry::Decided {
            decision: Decision::Transition {
                from: "a".into(),
                to: "stop".into(),
                code: 0,
                reason: String::new(),
            },
        },
    ));
    records.push(record(
        4,
        Entry::Observed {
            event: Event::SupervisorChose { state: "a".into() },
        },
    ));
    let recording = Recording::from_records(&records).unwrap();
    let comparison = compare(mission(with_gui), &recording);
    expect![[r#"
        after event 1 (exit code 0), decision 2:
          recorded: nothing more
          script:   finished | `a` led to `stop`"#]]
    .assert_eq(&comparison.difference.unwrap().to_string());
}

#[test]
fn records_that_are_not_one_mission_are_refused_with_a_reason() {
    let check = |records: &[Record], expected: RecordingError| {
        assert_eq!(Recording::from_records(records), Err(expected));
    };
    check(&[], RecordingError::Empty);
    check(
        &[record(
            5,
            Entry::Observed {
                event: Event::TimedOut,
            },
        )],
        RecordingError::NoStart { seq: 5 },
    );
    check(
        &[record(0, started()), record(1, started())],
        RecordingError::SecondMission { seq: 1 },
    );
}

#[test]
fn a_recording_of_several_missions_splits_at_each_start() {
    let check = |records: &[Record], expected: &[&[u64]]| {
        let got: Vec<Vec<u64>> = lewis_sequencer::split_missions(records)
            .iter()
            .map(|mission| mission.iter().map(|r| r.seq).collect())
            .collect();
        assert_eq!(got, expected);
    };
    let observed = || Entry::Observed {
        event: Event::TimedOut,
    };
    check(&[], &[]);
    check(&[record(0, started()), record(1, observed())], &[&[0, 1]]);
    check(
        &[
            record(0, started()),
            record(1, observed()),
            record(0, started()),
        ],
        &[&[0, 1], &[0]],
    );
    // A recording begun late: what comes before the first start is a mission of its own,
    // which replay refuses as cut.
    check(
        &[record(7, observed()), record(0, started())],
        &[&[7], &[0]],
    );
}

#[test]
fn a_line_that_is_not_a_record_is_reported_with_its_number() {
    let text = "\n{\"seq\":0,\"time_ns\":1,\"entry\":{\"type\":\"observed\",\"event\":{\"kind\":\"timed_out\"}}}\n{\"seq\":1}\n";
    match read_json_lines(text.as_bytes()) {
        Err(ReadError::Json { line, .. }) => assert_eq!(line, 3),
        other => panic!("expected an error on line 3, got {other:?}"),
    }
}

#[test]
fn every_kind_of_record_survives_a_json_round_trip() {
    let entries = vec![
        started(),
        Entry::Observed {
            event: Event::Signalled { signal: 11 },
        },
        Entry::Observed {
            event: Event::SpawnFailed {
                error: "gone".into(),
            },
        },
        Entry::Observed {
            event: Event::SupervisorStopped,
        },
        Entry::Observed {
            event: Event::Interrupted {
                reason: "SIGINT".into(),
            },
        },
        Entry::Refused {
            event: Event::TimedOut,
            error: "no".into(),
        },
        Entry::ProgramStarted {
            state: "a".into(),
            attempt: 2,
            pid: 42,
        },
        Entry::Decided {
            decision: Decision::AskSupervisor {
                choices: vec!["a".into()],
                suggested: Some("stop".into()),
                reason: "r".into(),
            },
        },
    ];
    for (seq, entry) in entries.into_iter().enumerate() {
        let record = record(seq as u64, entry);
        let json = serde_json::to_string(&record).unwrap();
        assert_eq!(
            serde_json::from_str::<Record>(&json).unwrap(),
            record,
            "{json}"
        );
    }
}
