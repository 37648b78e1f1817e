//! Records as `Sequencer` publications (CDR, what `/lewis/sequencer` carries) and back.

#![allow(clippy::unwrap_used, clippy::expect_used)]

use std::collections::BTreeMap;
use std::path::PathBuf;

use lewis_interfaces::cdr;
use lewis_interfaces::msg::Sequencer as SequencerMessage;
use lewis_sequencer::message::{MessageError, PROVIDER, from_message, to_message};
use lewis_sequencer::record::{Entry, Record};
use lewis_sequencer::{Decision, Event, Supervision};
use proptest::prelude::*;

fn name() -> impl Strategy<Value = String> {
    "[a-z][a-z0-9_]{0,8}"
}

fn text() -> impl Strategy<Value = String> {
    "\\PC{0,20}"
}

fn event() -> impl Strategy<Value = Event> {
    prop_oneof![
        any::<i32>().prop_map(|code| Event::Exited { code }),
        any::<i32>().prop_map(|signal| Event::Signalled { signal }),
        Just(Event::TimedOut),
        text().prop_map(|error| Event::SpawnFailed { error }),
        name().prop_map(|state| Event::SupervisorChose { state }),
        Just(Event::SupervisorStopped),
        text().prop_map(|reason| Event::Interrupted { reason }),
    ]
}

fn decision() -> impl Strategy<Value = Decision> {
    prop_oneof![
        (
            name(),
            "/[a-z/]{1,12}",
            prop::collection::vec(text(), 0..4),
            prop::collection::btree_map(name(), text(), 0..3),
            prop::option::of(any::<i64>()),
            any::<u32>(),
            text()
        )
            .prop_map(|(state, program, args, env, timeout_ns, attempt, reason)| {
                Decision::Run {
                    state,
                    program: PathBuf::from(program),
                    args,
                    env,
                    timeout_ns,
                    attempt,
                    reason,
                }
            }),
        (name(), any::<u32>(), text()).prop_map(|(state, attempt, reason)| Decision::Restart {
            state,
            attempt,
            reason
        }),
        (name(), text()).prop_map(|(from, reason)| Decision::EnterRecovery { from, reason }),
        (
            prop::collection::vec(name(), 0..5),
            prop::option::of(name()),
            text()
        )
            .prop_map(|(choices, suggested, reason)| Decision::AskSupervisor {
                choices,
                suggested,
                reason
            }),
        (name(), text()).prop_map(|(state, reason)| Decision::Resume { state, reason }),
        (name(), name(), any::<i32>(), text()).prop_map(|(from, to, code, reason)| {
            Decision::Transition {
                from,
                to,
                code,
                reason,
            }
        }),
        text().prop_map(|reason| Decision::Finished { reason }),
        text().prop_map(|reason| Decision::Aborted { reason }),
    ]
}

fn entry() -> impl Strategy<Value = Entry> {
    prop_oneof![
        (
            "/[a-z/]{1,12}",
            prop::collection::vec(name(), 0..5),
            any::<bool>(),
            prop::option::of(prop::sample::select(
                &[
                    Supervision::Page,
                    Supervision::Terminal,
                    Supervision::Unattended
                ][..]
            ))
        )
            .prop_map(
                |(script, states, use_gui, supervision)| Entry::MissionStarted {
                    script: PathBuf::from(script),
                    states,
                    use_gui,
                    supervision,
                }
            ),
        event().prop_map(|event| Entry::Observed { event }),
        (event(), text()).prop_map(|(event, error)| Entry::Refused { event, error }),
        decision().prop_map(|decision| Entry::Decided { decision }),
        (name(), any::<u32>(), any::<u32>()).prop_map(|(state, attempt, pid)| {
            Entry::ProgramStarted {
                state,
                attempt,
                pid,
            }
        }),
    ]
}

fn record() -> impl Strategy<Value = Record> {
    (0..u64::MAX - 1, any::<i64>(), entry()).prop_map(|(seq, time_ns, entry)| Record {
        seq,
        time_ns,
        entry,
    })
}

proptest! {
    #[test]
    fn every_record_survives_the_cdr_publication(record in record()) {
        let message = to_message(&record);
        let bytes = cdr::to_vec(&message);
        let decoded: SequencerMessage = cdr::from_bytes(&bytes).unwrap();
        prop_assert_eq!(from_message(&decoded), Ok(record));
    }
}

#[test]
fn the_header_numbers_records_from_one_and_names_the_sequencer() {
    let message = to_message(&Record {
        seq: 0,
        time_ns: 1_700_000_000_000_000_000,
        entry: Entry::Decided {
            decision: Decision::Transition {
                from: "door".into(),
                to: "sign".into(),
                code: 0,
                reason: "door exited with 0".into(),
            },
        },
    });
    assert_eq!(
        (
            message.header.seq,
            message.header.publish_time_ns,
            message.header.provider.as_str()
        ),
        (1, 1_700_000_000_000_000_000, PROVIDER)
    );
    assert_eq!(
        [
            message.entry.as_str(),
            &message.kind,
            &message.state,
            &message.to
        ],
        ["decided", "transition", "door", "sign"]
    );
}

#[test]
fn publications_that_are_no_record_are_refused_with_the_reason() {
    fn check(edit: impl FnOnce(&mut SequencerMessage), expected: &MessageError) {
        let mut message = to_message(&Record {
            seq: 4,
            time_ns: 0,
            entry: Entry::Decided {
                decision: Decision::Run {
                    state: "door".into(),
                    program: "/bin/true".into(),
                    args: vec![],
                    env: BTreeMap::from([("A".into(), "1".into())]),
                    timeout_ns: None,
                    attempt: 1,
                    reason: String::new(),
                },
            },
        });
        edit(&mut message);
        assert_eq!(from_message(&message).as_ref(), Err(expected));
    }
    check(|m| m.header.seq = 0, &MessageError::NoSeq);
    check(
        |m| m.entry = "teleported".into(),
        &MessageError::UnknownEntry {
            seq: 4,
            entry: "teleported".into(),
        },
    );
    check(
        |m| m.kind = "dance".into(),
        &MessageError::UnknownKind {
            seq: 4,
            what: "decision",
            kind: "dance".into(),
        },
    );
    check(
        |m| {
            m.entry = "observed".into();
            m.kind = "dance".into();
        },
        &MessageError::UnknownKind {
            seq: 4,
            what: "event",
            kind: "dance".into(),
        },
    );
    check(
        |m| m.env_values.clear(),
        &MessageError::Environment {
            seq: 4,
            names: 1,
            values: 0,
        },
    );
}
